#!/usr/bin/env bash
# The main job on the built-in sample: sets up (Debian packages), builds, and runs
# `vmsim simulate-part` on sample part 1 of the second paper on the Mikron UCP710 sample
# (production 10 m/min against the 0.1 m/min reference), then says where the results are.
# Run as root on a fresh Debian 12 machine. Renders need an X display: without one the job runs
# under xvfb-run (installed by the set-up).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-debian.sh
bash scripts/setup-web.sh  # vtk.js for the report's 3-D view (npm, pinned in viz/web)
bash scripts/build.sh
build_dir=${VMSIM_BUILD_DIR:-build}
out=${VMSIM_OUT:-out/sample}
vmsim="$build_dir/app/vmsim"

run_with_display() {
  if [[ -n "${DISPLAY:-}" ]]; then
    "$@"
  else
    xvfb-run -a -s "-screen 0 1280x1024x24" "$@"
  fi
}

# A result of a vmsim from before result folders carried their marker (.vmsim-result) is refused
# as a folder vmsim did not write: this script's own output folder is cleared of such a result.
if [[ -d "$out" && ! -e "$out/.vmsim-result" && -e "$out/report.json" ]]; then
  echo "== removing $out: a result of an earlier vmsim (no .vmsim-result marker)"
  rm -rf "$out"
fi

echo "== simulate-part: sample part 1 (second paper), Mikron UCP710, 10 m/min vs 0.1 m/min"
run_with_display "$vmsim" simulate-part --out "$out"

echo "== inverse kinematics of every sample path on its machine (set points, corners, singular zones)"
mkdir -p "$out/kinematics"
for part in samples/parts/*/part.yaml; do
  name=$(basename "$(dirname "$part")")
  # The die-sized parts (issue 21) are for the scale runs: their tool paths are generated on
  # demand and git-ignored (samples/parts/README.md), and their set points would be 100 MB.
  case "$name" in die_*) echo "   $name: skipped (a scale part: README, \"Scale\")"; continue ;; esac
  "$vmsim" --quiet kinematics --part "$part" --out "$out/kinematics/$name.axes.csv" \
    --summary "$out/kinematics/$name.json"
done
echo "== actuator torques along path 1 of the first paper (Mikron, 10 m/min)"
"$vmsim" dynamics --part samples/parts/path1_yz/part.yaml --feed-mm-per-min 10000 \
  --out "$out/kinematics/path1_yz.dynamics.csv"
echo
echo "results in $out/: report.html (open it in a browser), report.json, surfaces (.vtp), images:"
ls -1 "$out"
