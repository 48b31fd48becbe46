#!/usr/bin/env bash
# Installs, from the npm registry, what the report's 3-D view and its browser test run, pinned by
# viz/web/package-lock.json: vtk.js (its browser build is copied into every simulate-part result
# folder; app/report_3d.hpp) and playwright-core (drives Debian's chromium in ctest
# report.browser). Into viz/web/node_modules; nothing is installed globally.
# Idempotent: returns at once when the installed modules match the lock.
# Without node/npm or without the registry it warns and exits 0: simulate-part then writes its
# report without the 3-D view, and says there how to get it.
set -euo pipefail
cd "$(dirname "$0")/../viz/web"
installed=node_modules/.package-lock.json  # npm's record of what it installed
if [[ -f node_modules/vtk.js/vtk.js && -d node_modules/playwright-core && -f "$installed" &&
      "$installed" -nt package-lock.json ]]; then
  echo "setup-web: vtk.js and playwright-core present"
  exit 0
fi
if ! command -v npm > /dev/null; then
  echo "setup-web: WARNING: npm not found (scripts/setup-debian.sh installs it): reports will have no 3-D view" >&2
  exit 0
fi
echo "setup-web: npm ci in viz/web (vtk.js, playwright-core)"
if ! npm ci --ignore-scripts --no-audit --no-fund --loglevel=error; then
  echo "setup-web: WARNING: npm ci failed: reports will have no 3-D view until this script succeeds" >&2
  exit 0
fi
echo "setup-web: done"
