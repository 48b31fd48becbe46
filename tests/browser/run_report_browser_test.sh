#!/usr/bin/env bash
# ctest report.browser: simulate-part on sample part 1 at a coarse grid (50 um, for time), then
# its report.html in headless chromium (report_browser_test.cjs says what is checked).
# Skipped (exit 77, ctest: "Skipped") only where chromium is not installed; every other missing
# piece (node, playwright-core, vtk.js) is a failure: scripts/run-tests.sh installs them.
# Usage: run_report_browser_test.sh VMSIM_BINARY SOURCE_DIR WORK_DIR [--update-baseline]
set -euo pipefail
vmsim=$1 source_dir=$2 work=$3
shift 3
chromium=${VMSIM_CHROMIUM:-/usr/bin/chromium}
if [[ ! -x "$chromium" ]]; then
  echo "SKIPPED: no chromium at $chromium (Debian package chromium; scripts/run-tests.sh installs it)"
  exit 77
fi
if ! command -v node > /dev/null; then
  echo "FAILED: node is not installed (scripts/setup-debian.sh installs it)" >&2
  exit 1
fi
export VMSIM_WEB_MODULES="$source_dir/viz/web/node_modules"
for module in playwright-core vtk.js; do
  if [[ ! -d "$VMSIM_WEB_MODULES/$module" ]]; then
    echo "FAILED: $module is not installed in viz/web: run bash scripts/setup-web.sh" >&2
    exit 1
  fi
done

# WORK_DIR is this test's own: removed only where it made it (its marker inside) or where it is
# empty, never a folder of the user's given by hand.
marker="$work/.vmsim-browser-test"
if [[ -e "$work" && ! -f "$marker" && -n "$(ls -A "$work" 2>/dev/null)" ]]; then
  echo "FAILED: $work exists and was not made by this test: give a new or empty folder" >&2
  exit 1
fi
rm -rf "$work"
mkdir -p "$work"
touch "$marker"
run=("$vmsim" --quiet simulate-part --grid-um 50 --out "$work/result")
if [[ -n "${DISPLAY:-}" ]]; then
  "${run[@]}"
else
  xvfb-run -a -s "-screen 0 1280x1024x24" "${run[@]}"
fi
node "$source_dir/tests/browser/report_browser_test.cjs" "$work/result" \
  "$source_dir/tests/browser/baseline_view3d.json" "$work/shots" "$@"
