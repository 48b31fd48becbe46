#!/usr/bin/env bash
# Installs the Debian 12 packages the vmsim build and tests need (run as root).
# Idempotent: when every package is present it only checks and returns in about a second.
# Keep this list in step with the find_package() calls in CMakeLists.txt (DEBIAN-NOTES trap 5).
# Extra arguments are further packages to install the same way (scripts/run-fuzz.sh: clang).
set -euo pipefail

packages=(
  cmake g++ make pkg-config
  libgtest-dev libgmock-dev libbenchmark-dev
  libeigen3-dev          # Eigen 3.4: all linear algebra
  libyaml-cpp-dev        # machine description files
  nlohmann-json3-dev     # JSON reports
  libcli11-dev           # the vmsim command line
  zlib1g-dev             # the report's 3-D view data, compressed
  liburdfdom-dev         # robots loaded from URDF
  liborocos-kdl-dev      # independent reference for the kinematics tests
  libtbb-dev             # parallel loops
  coinor-libclp-dev      # LP solver (CLP) for the third-order feedrate planning
  libopenvdb-dev libboost-iostreams-dev  # level-set material removal (OpenVDB's CMake needs boost_iostreams)
  libvtk9-dev xvfb xauth libgl1-mesa-dri   # off-screen rendering (viz)
  fonts-dejavu-core      # viz text: VTK 9.1's embedded Arial draws [ ] as ( )
  libopenmpi-dev openmpi-bin  # simulate-part over several processes (mpirun; app/mpi_ranks.hpp)
  python3 time           # bench/scaling.py (peak memory and CPU from /usr/bin/time -v)
  "$@"
)
# Node.js and npm install the report's 3-D viewer library (scripts/setup-web.sh). Debian's packages
# only where no node/npm is there already (a machine may have Node.js from elsewhere, with npm
# built in: Debian's npm would conflict with it).
if ! command -v node > /dev/null || ! command -v npm > /dev/null; then
  packages+=(nodejs npm)
fi

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$package")
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

if [[ $(id -u) -ne 0 ]]; then
  echo "setup: missing packages: ${missing[*]}" >&2
  echo "setup: run this script as root (or install them with apt-get) and try again" >&2
  exit 1
fi

echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
