#!/usr/bin/env python3
"""The end-to-end job (vmsim simulate-part) at several sizes, and the growth law fitted from it.

Sizes: part 1's profile swept over W mm in y (generate_parts --die-width-mm W; W = 10 is sample
part 1 itself) at Z-map grids G um. Each run is measured by the kernel (/usr/bin/time -v: peak
RSS, user + sys CPU, wall) and by the report's own per-stage clocks (report.json:
stage_seconds, stage_cpu_seconds, stage_peak_rss_mib). The fits, by least squares:

    CPU [s]       = a * area [mm2] + b * Z-map lines
    peak RSS [B]  = c + d * machine time [s] (both runs) + e * Z-map lines

Usage (from the top of the source tree, after building vmsim and generate_parts):

    python3 bench/scaling.py --widths 10,20 --grids 40,20 [--threads 2] [--out /tmp/vmsim-scaling]

The CI runs the smallest version (--widths 10 --grids 40). Prints a table a run a line, the
stages of the largest run, and the fitted laws; writes <out>/scaling.json.
"""
import argparse
import json
import os
import re
import subprocess
import sys


def solve(rows, values):
    """Least squares: the x minimising |A x - b| by the normal equations (a few unknowns)."""
    n = len(rows[0])
    ata = [[sum(r[i] * r[j] for r in rows) for j in range(n)] for i in range(n)]
    atb = [sum(r[i] * v for r, v in zip(rows, values)) for i in range(n)]
    for col in range(n):  # Gauss-Jordan with partial pivoting
        pivot = max(range(col, n), key=lambda k: abs(ata[k][col]))
        if abs(ata[pivot][col]) < 1e-300:
            return None
        ata[col], ata[pivot] = ata[pivot], ata[col]
        atb[col], atb[pivot] = atb[pivot], atb[col]
        for k in range(n):
            if k != col:
                f = ata[k][col] / ata[col][col]
                ata[k] = [a - f * b for a, b in zip(ata[k], ata[col])]
                atb[k] -= f * atb[col]
    return [atb[i] / ata[i][i] for i in range(n)]


def time_v(text):
    """Peak RSS [B], CPU [s] and wall [s] from /usr/bin/time -v's report."""
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1)) * 1024
    user = float(re.search(r"User time \(seconds\): ([\d.]+)", text).group(1))
    system = float(re.search(r"System time \(seconds\): ([\d.]+)", text).group(1))
    wall_text = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): ([\d:.]+)", text).group(1)
    wall = 0.0
    for part in wall_text.split(":"):
        wall = wall * 60 + float(part)
    return rss, user + system, wall


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", default=os.environ.get("VMSIM_BUILD_DIR", "build"))
    parser.add_argument("--widths", default="10,20", help="widths in y [mm], comma-separated")
    parser.add_argument("--grids", default="40,20", help="Z-map grids [um], comma-separated")
    parser.add_argument("--threads", type=int, default=0)
    parser.add_argument("--out", default="/tmp/vmsim-scaling")
    parser.add_argument("--extra", default="", help="more vmsim simulate-part options, space-separated")
    args = parser.parse_args()
    vmsim = os.path.join(args.build, "app", "vmsim")
    generator = os.path.join(args.build, "samples", "generate_parts")
    os.makedirs(args.out, exist_ok=True)
    # The part files name their machine as ../../machines/<file> (samples/ layout).
    machines = os.path.join(args.out, "machines")
    if not os.path.exists(machines):
        os.symlink(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "samples", "machines"), machines)
    results = []
    for width in [float(w) for w in args.widths.split(",")]:
        parts = os.path.join(args.out, "parts")
        subprocess.run([generator, "--die-width-mm", f"{width:g}", parts], check=True, stdout=subprocess.DEVNULL)
        name = "part1_tangency" if width == 10 else f"die_part1_{width:g}mm"
        part = os.path.join(parts, name, "part.yaml")
        for grid in [float(g) for g in args.grids.split(",")]:
            out = os.path.join(args.out, f"{name}_{grid:g}um")
            command = ["/usr/bin/time", "-v", vmsim, "-q", "simulate-part", "--part", part, "--out", out,
                       "--grid-um", f"{grid:g}", "--no-renders", "--threads", str(args.threads)]
            command += [word for word in args.extra.split() if word]
            done = subprocess.run(command, capture_output=True, text=True)
            if done.returncode != 0:
                sys.exit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
            rss, cpu, wall = time_v(done.stderr)
            with open(os.path.join(out, "report.json")) as f:
                report = json.load(f)
            stock = report["stock"]
            area = (stock["max_mm"][0] - stock["min_mm"][0]) * (stock["max_mm"][1] - stock["min_mm"][1])
            machine_s = sum(report["runs"][run]["duration_s"] for run in ("production", "reference"))
            results.append({
                "part": name, "width_mm": width, "grid_um": grid, "area_mm2": area,
                "zmap_lines": report["surface"]["lines"], "machine_time_s": machine_s,
                "path_points": report["runs"]["production"]["servo_samples"],
                "cpu_s": cpu, "wall_s": wall, "peak_rss_bytes": rss,
                "stage_seconds": report["stage_seconds"],
                "stage_cpu_seconds": report.get("stage_cpu_seconds", {}),
                "stage_peak_rss_mib": report.get("stage_peak_rss_mib", {}),
                "deepest_mark_um": report["marks"][0]["depth_um"] if report["marks"] else 0.0,
            })
            r = results[-1]
            print(f"{name:22s} {grid:5g} um  {r['zmap_lines']:>11,d} lines  {area:8.0f} mm2  "
                  f"machine {machine_s:8.0f} s  CPU {cpu:7.1f} s  wall {wall:7.1f} s  "
                  f"peak {rss / 2**30:6.2f} GiB  deepest mark {r['deepest_mark_um']:.2f} um", flush=True)
    largest = max(results, key=lambda r: r["cpu_s"])
    print(f"\nstages of {largest['part']} at {largest['grid_um']:g} um (wall s / CPU s / peak RSS MiB at the end):")
    cpu_stages = largest["stage_cpu_seconds"]
    rss_stages = largest["stage_peak_rss_mib"]
    for key, value in largest["stage_seconds"].items():
        if isinstance(value, dict):
            for stage, seconds in value.items():
                c = cpu_stages.get(key, {}).get(stage, float("nan")) if isinstance(cpu_stages.get(key), dict) else float("nan")
                m = rss_stages.get(key, {}).get(stage, float("nan")) if isinstance(rss_stages.get(key), dict) else float("nan")
                print(f"  {key + '.' + stage:36s} {seconds:8.2f} {c:8.2f} {m:9.0f}")
        else:
            c = cpu_stages.get(key, float("nan"))
            m = rss_stages.get(key, float("nan"))
            c = c if not isinstance(c, dict) else float("nan")
            m = m if not isinstance(m, dict) else float("nan")
            print(f"  {key:36s} {value:8.2f} {c:8.2f} {m:9.0f}")
    fits = {}
    if len(results) >= 2:
        cpu_fit = solve([[r["area_mm2"], r["zmap_lines"]] for r in results], [r["cpu_s"] for r in results])
        if cpu_fit:
            fits["cpu_s_per_800_mm2"] = cpu_fit[0] * 800
            fits["cpu_us_per_line"] = cpu_fit[1] * 1e6
            print(f"\nCPU ~ {cpu_fit[0] * 800:.2f} s per 800 mm2 + {cpu_fit[1] * 1e6:.2f} us per Z-map line")
    if len(results) >= 3:
        rss_fit = solve([[1.0, r["machine_time_s"], r["zmap_lines"]] for r in results],
                        [r["peak_rss_bytes"] for r in results])
        if rss_fit:
            fits["rss_base_gib"] = rss_fit[0] / 2**30
            fits["rss_bytes_per_machine_second"] = rss_fit[1]
            fits["rss_bytes_per_line"] = rss_fit[2]
            print(f"peak RSS ~ {rss_fit[0] / 2**30:.3f} GiB + {rss_fit[1] / 1e3:.1f} kB per second of machine time"
                  f" + {rss_fit[2]:.1f} B per Z-map line")
    with open(os.path.join(args.out, "scaling.json"), "w") as f:
        json.dump({"runs": results, "fits": fits}, f, indent=1)


if __name__ == "__main__":
    main()
