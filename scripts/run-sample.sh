#!/usr/bin/env bash
# The main job on the built-in sample: sets up (Debian packages), builds, and runs the most
# complete part of the chain that exists today on sample part 1 (second paper) on the Mikron
# UCP710 sample, then says where the results are. Run as root on a fresh Debian 12 machine.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-debian.sh
bash scripts/build.sh
build_dir=${VMSIM_BUILD_DIR:-build}
out=${VMSIM_OUT:-out/sample}
mkdir -p "$out"
vmsim="$build_dir/app/vmsim"

echo "== inverse kinematics of every sample path on its machine"
for part in samples/parts/*/part.yaml; do
  name=$(basename "$(dirname "$part")")
  "$vmsim" kinematics --part "$part" --out "$out/$name.axes.csv" --summary "$out/$name.kinematics.json"
done
if "$vmsim" --help | grep -q "^  dynamics"; then
  echo "== actuator torques along path 1 of the first paper (Mikron, 10 m/min)"
  "$vmsim" dynamics --part samples/parts/path1_yz/part.yaml --feed-mm-per-min 10000 \
    --out "$out/path1_yz.dynamics.csv"
fi
echo
echo "results in $out/:"
ls -1 "$out"
