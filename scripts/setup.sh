#!/usr/bin/env bash
# Installs the Debian packages Gimlet builds and runs against, only when one is
# missing. Safe to run again: when everything is present it runs no apt-get at
# all and prints nothing.
#
#   bash scripts/setup.sh          # as root, or as a user with sudo
set -euo pipefail

packages=(
  libopenmpi-dev openmpi-bin        # MPI (mpi-sys, mpiexec)
  libhdf5-openmpi-dev hdf5-tools    # parallel HDF5 (hdf5-sys) and h5dump
  libpetsc-real-dev                 # PETSc 3.18 (crates/petsc-sys)
  cmake gfortran pkg-config         # the C/C++/Fortran build frame
  libclang-dev                      # bindgen (mpi-sys, petsc-sys)
  python3-matplotlib python3-numpy  # plots of the results
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$'; then
    missing+=("$p")
  fi
done
[ "${#missing[@]}" -eq 0 ] && exit 0

if [ "$(id -u)" -eq 0 ]; then
  as_root=()
elif command -v sudo >/dev/null 2>&1; then
  as_root=(sudo)
else
  echo "setup.sh: missing Debian packages: ${missing[*]}" >&2
  echo "setup.sh: not root and no sudo; install them as root with:" >&2
  echo "  apt-get update && apt-get install -y --no-install-recommends ${missing[*]}" >&2
  exit 1
fi

echo "setup.sh: installing ${missing[*]}" >&2
log=$(mktemp)
trap 'rm -f "$log"' EXIT
if ! { "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive apt-get update &&
       "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive \
         apt-get install -y --no-install-recommends "${missing[@]}"; } >"$log" 2>&1; then
  cat "$log" >&2
  echo "setup.sh: apt-get failed (log above)" >&2
  exit 1
fi
