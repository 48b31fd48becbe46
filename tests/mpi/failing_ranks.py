#!/usr/bin/env python3
"""simulate-part under mpirun when something fails: every rank ends, mpirun exits with the
error's code (3: bad input), and no output folder (nor a staging folder beside it) is left.

Two failures: a bad input every rank reads alike (a part file naming a tool path that does not
exist), and one only rank 0 sees (--out is an existing file: rank 0 alone checks the output
folder, the other ranks have started computing and are ended by rank 0's MPI_Abort).

    failing_ranks.py --vmsim build/app/vmsim --mpirun /usr/bin/mpirun --part samples/.../part.yaml --work /tmp/x
"""
import argparse
import os
import pathlib
import shutil
import subprocess
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--vmsim", required=True)
    parser.add_argument("--mpirun", required=True)
    parser.add_argument("--part", required=True, help="a valid part file (copied with a bad tool path)")
    parser.add_argument("--work", required=True)
    options = parser.parse_args()
    work = pathlib.Path(options.work)
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    part = pathlib.Path(options.part).resolve()
    bad_part = work / "bad_part.yaml"
    text = part.read_text().replace("toolpath: toolpath.apt", "toolpath: no_such_toolpath.apt")
    text = text.replace("machine: ../../machines/", f"machine: {part.parent.parent.parent}/machines/")
    bad_part.write_text(text)
    (work / "a_file").write_text("not a folder\n")
    mpirun = [options.mpirun, *(["--allow-run-as-root"] if os.geteuid() == 0 else []), "--oversubscribe", "-np", "2",
              options.vmsim, "-q", "simulate-part", "--grid-um", "200", "--no-renders"]
    cases = [("bad input on every rank", ["--part", str(bad_part), "--out", str(work / "out")], 3),
             ("output folder refused on rank 0 only", ["--part", str(part), "--out", str(work / "a_file")], 3)]
    problems = []
    for name, args, expected in cases:
        result = subprocess.run(mpirun + args, capture_output=True, text=True, timeout=600)
        if result.returncode != expected:
            problems.append(f"{name}: exit {result.returncode}, expected {expected}\n{result.stdout}{result.stderr}")
        if "error:" not in result.stderr:
            problems.append(f"{name}: no error message\n{result.stderr}")
        left = sorted(p.name for p in work.iterdir() if p.name not in ("bad_part.yaml", "a_file"))
        if left:
            problems.append(f"{name}: left {left}")
        if (work / "a_file").read_text() != "not a folder\n":
            problems.append(f"{name}: a_file was changed")
    for problem in problems:
        print("PROBLEM:", problem)
    print(f"{len(cases)} failing MPI runs: {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
