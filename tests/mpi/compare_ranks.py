#!/usr/bin/env python3
"""simulate-part on one process against the same run under mpirun with several ranks.

Runs `vmsim simulate-part <args>` once as one process and once as `mpirun -np N` (as root:
--allow-run-as-root; --oversubscribe: more ranks than cores), then checks that the results are
the same: report.json key by key except the clocks and the ranks' own figures (stage_seconds,
stage_cpu_seconds, stage_peak_rss_mib, the date, the command line, "processes",
view_3d.seconds), and every other file (heights *.bin, marks.csv, .vtp, images, the 3-D view's
data) byte for byte but report.html (it shows the date and the command line). Then checks
that only rank 0 wrote: the output folder holds the same file names, and nothing else was
left beside it. Exit 0 when all agree, 1 with the differences listed.

    compare_ranks.py --vmsim build/app/vmsim --mpirun /usr/bin/mpirun --ranks 2 --work /tmp/x -- \
        --part samples/parts/part1_tangency/part.yaml --grid-um 200 --no-renders
"""
import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys

IGNORED_KEYS = {"stage_seconds", "stage_cpu_seconds", "stage_peak_rss_mib", "processes", "date_utc", "command_line"}


def differences(a, b, path=""):
    """Key by key differences between two JSON values (the ignored keys skipped)."""
    out = []
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if key in IGNORED_KEYS or (path == "/view_3d" and key == "seconds"):
                continue
            if key not in a or key not in b:
                out.append(f"{path}/{key}: only in {'the single run' if key in a else 'the MPI run'}")
                continue
            out += differences(a[key], b[key], f"{path}/{key}")
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: {len(a)} items against {len(b)}")
        for i, (x, y) in enumerate(zip(a, b)):
            out += differences(x, y, f"{path}[{i}]")
    elif a != b or type(a) is not type(b):
        out.append(f"{path}: {a!r} against {b!r}")
    return out


def run(command, log):
    with open(log, "w") as stream:
        result = subprocess.run(command, stdout=stream, stderr=subprocess.STDOUT)
    if result.returncode != 0:
        sys.stdout.write(open(log).read())
        sys.exit(f"failed (exit {result.returncode}): {' '.join(command)}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--vmsim", required=True)
    parser.add_argument("--mpirun", required=True)
    parser.add_argument("--ranks", type=int, required=True)
    parser.add_argument("--work", required=True, help="a folder for both runs (emptied first)")
    parser.add_argument("args", nargs=argparse.REMAINDER, help="-- then the simulate-part arguments")
    options = parser.parse_args()
    args = options.args[1:] if options.args[:1] == ["--"] else options.args
    work = pathlib.Path(options.work)
    shutil.rmtree(work, ignore_errors=True)
    (work / "single").mkdir(parents=True)
    (work / "ranks").mkdir(parents=True)
    single, ranked = work / "single" / "out", work / "ranks" / "out"
    run([options.vmsim, "-q", "simulate-part", *args, "--out", str(single)], work / "single.log")
    environment_flags = ["--allow-run-as-root"] if os.geteuid() == 0 else []
    run([options.mpirun, *environment_flags, "--oversubscribe", "-np", str(options.ranks), options.vmsim, "-q",
         "simulate-part", *args, "--out", str(ranked)], work / "ranks.log")

    problems = []
    a = json.loads((single / "report.json").read_text())
    b = json.loads((ranked / "report.json").read_text())
    problems += differences(a, b)
    processes = b.get("processes", {})
    if processes.get("ranks") != options.ranks:
        problems.append(f"report.json processes.ranks: {processes.get('ranks')} (expected {options.ranks})")
    names_a = sorted(str(p.relative_to(single)) for p in single.rglob("*") if p.is_file())
    names_b = sorted(str(p.relative_to(ranked)) for p in ranked.rglob("*") if p.is_file())
    if names_a != names_b:
        problems.append(f"files differ: {names_a} against {names_b}")
    # Every other file byte for byte (report.html shows the date and the command line).
    compared = 0
    for name in names_a:
        if name in ("report.json", "report.html") or name not in names_b:
            continue
        compared += 1
        if (single / name).read_bytes() != (ranked / name).read_bytes():
            problems.append(f"{name}: not byte-identical")
    if sum(name.endswith(".bin") for name in names_a) < 2 or "marks.csv" not in names_a:
        problems.append("no heights (.bin) or no marks.csv to compare")
    # Only rank 0 wrote: nothing but the output folder beside it (no other rank's staging).
    beside = sorted(p.name for p in (work / "ranks").iterdir())
    if beside != ["out"]:
        problems.append(f"beside the output folder: {beside}")
    for problem in problems:
        print("DIFFERENT:", problem)
    print(f"{options.ranks} ranks against 1 process: {len(problems)} differences; "
          f"{compared} files byte for byte and report.json ({len(a)} top-level keys) compared; "
          f"bands {json.dumps(processes.get('bands'))}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
