#!/usr/bin/env bash
# The whole test suite: sets up (Debian packages), builds, runs ctest. Run as root on a fresh
# Debian 12 machine. Extra arguments go to ctest (e.g. -R Trace).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-debian.sh chromium  # chromium: the report's browser test (ctest report.browser)
bash scripts/setup-web.sh              # vtk.js and playwright-core (npm, pinned in viz/web)
bash scripts/build.sh
build_dir=${VMSIM_BUILD_DIR:-build}
cd "$build_dir"
ctest --output-on-failure -j"${VMSIM_JOBS:-$(nproc)}" "$@"
