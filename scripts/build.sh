#!/usr/bin/env bash
# Configures and builds vmsim (Release) in ${VMSIM_BUILD_DIR:-build}. Used by the two README
# commands; safe to run again (incremental).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${VMSIM_BUILD_DIR:-build}
jobs=${VMSIM_JOBS:-$(nproc)}
cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=Release "$@" > "$build_dir.configure.log" 2>&1 || {
  cat "$build_dir.configure.log" >&2
  echo "build: configuring failed (log above)" >&2
  exit 1
}
cmake --build "$build_dir" -j"$jobs"
