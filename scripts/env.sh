# Environment for building and running Gimlet; source it:  . scripts/env.sh
#
# Open MPI: allow mpiexec as root (containers, CI) and more ranks than cores
# (the machines here have 2).
export OMPI_ALLOW_RUN_AS_ROOT=1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
# hdf5-sys 0.8 looks at HDF5_DIR (include/ and lib/ below it) before
# pkg-config `hdf5`, whose Debian alternative may point to the serial build:
# pin the Open MPI flavour, the one PETSc and Gimlet's collective output use.
if [ -z "${HDF5_DIR:-}" ]; then
  gimlet_multiarch=$(dpkg-architecture -qDEB_HOST_MULTIARCH 2>/dev/null ||
    gcc -print-multiarch 2>/dev/null || echo x86_64-linux-gnu)
  if [ -d "/usr/lib/$gimlet_multiarch/hdf5/openmpi/include" ]; then
    export HDF5_DIR="/usr/lib/$gimlet_multiarch/hdf5/openmpi"
  fi
  unset gimlet_multiarch
fi
