# Script mode (cmake -P), run at build time by the `gimlet_cargo` target.
#
# 1. Builds the `gimlet` library crate with cargo (release), which produces
#    libgimlet.so (cdylib; build.rs gives it the SONAME libgimlet.so.<major>),
#    libgimlet.a (staticlib) and the rlib in one compile. The build is the
#    one `cargo test --release` and `cargo clippy --release` make too (same
#    flags, features and target directory), so none of them recompiles the
#    library for another. rustc names the native libraries a static link
#    needs (`--print=native-static-libs`, in .cargo/config.toml).
# 2. Stages the libraries into STAGE_DIR under their versioned names
#    (libgimlet.so.X.Y.Z, libgimlet.so.X -> it, libgimlet.so -> it, libgimlet.a).
# 3. Writes NATIVE_FILE (a CMake file setting GIMLET_NATIVE_STATIC_LIBS, read by
#    the installed GimletConfig.cmake) and PC_OUT (gimlet.pc from PC_IN).
#
# Inputs (-D): CARGO, MANIFEST, TARGET_DIR, HDF5_DIR (may be empty), SONAME,
# VERSION, STAGE_DIR, NATIVE_FILE, PC_IN, PC_OUT, PC_RELPREFIX, LIBDIR,
# MPI_PC, HDF5_PC, PETSC_PC, JOBS (may be empty).

foreach(var CARGO MANIFEST TARGET_DIR SONAME VERSION STAGE_DIR NATIVE_FILE
            PC_IN PC_OUT PC_RELPREFIX LIBDIR MPI_PC HDF5_PC PETSC_PC)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "GimletCargoBuild.cmake: -D${var}=... is required")
  endif()
endforeach()

set(env_args "CARGO_TARGET_DIR=${TARGET_DIR}")
if(HDF5_DIR)
  list(APPEND env_args "HDF5_DIR=${HDF5_DIR}")
endif()
set(job_args)
if(JOBS)
  set(job_args -j ${JOBS})
endif()

execute_process(
  COMMAND ${CMAKE_COMMAND} -E env ${env_args}
          ${CARGO} build --release --lib -p gimlet --manifest-path ${MANIFEST} ${job_args}
  RESULT_VARIABLE rc
  ERROR_VARIABLE err
  ECHO_ERROR_VARIABLE)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cargo build of the gimlet library failed (exit ${rc})")
endif()

# rustc prints the line when it links the staticlib; cargo replays it from its
# cache when nothing changed. Keep the last good file if it is absent.
if(err MATCHES "native-static-libs: ([^\r\n]*)")
  string(STRIP "${CMAKE_MATCH_1}" native)
  set(content "# Written by GimletCargoBuild.cmake from rustc --print native-static-libs.\n")
  string(APPEND content "# Native libraries a static link of libgimlet.a needs, in rustc's order.\n")
  string(APPEND content "set(GIMLET_NATIVE_STATIC_LIBS \"${native}\")\n")
  set(old "")
  if(EXISTS "${NATIVE_FILE}")
    file(READ "${NATIVE_FILE}" old)
  endif()
  if(NOT old STREQUAL content)
    file(WRITE "${NATIVE_FILE}" "${content}")
  endif()
elseif(NOT EXISTS "${NATIVE_FILE}")
  message(FATAL_ERROR "rustc printed no native-static-libs line: the RUSTFLAGS environment variable replaces "
                      "the flags of .cargo/config.toml; unset it, or add --print=native-static-libs to it")
endif()
include("${NATIVE_FILE}")

# Stage the libraries under their installed names.
set(out "${TARGET_DIR}/release")
file(MAKE_DIRECTORY "${STAGE_DIR}")
file(COPY_FILE "${out}/libgimlet.so" "${STAGE_DIR}/libgimlet.so.${VERSION}" ONLY_IF_DIFFERENT)
file(COPY_FILE "${out}/libgimlet.a" "${STAGE_DIR}/libgimlet.a" ONLY_IF_DIFFERENT)
foreach(link "${SONAME}" libgimlet.so)
  set(dest "")
  if(IS_SYMLINK "${STAGE_DIR}/${link}")
    file(READ_SYMLINK "${STAGE_DIR}/${link}" dest)
  endif()
  if(NOT dest STREQUAL "libgimlet.so.${VERSION}")
    file(REMOVE "${STAGE_DIR}/${link}")
    file(CREATE_LINK "libgimlet.so.${VERSION}" "${STAGE_DIR}/${link}" SYMBOLIC)
  endif()
endforeach()

# gimlet.pc: relocatable (prefix found from the .pc file's own directory).
set(GIMLET_VERSION "${VERSION}")
set(GIMLET_PC_RELPREFIX "${PC_RELPREFIX}")
set(GIMLET_INSTALL_LIBDIR "${LIBDIR}")
set(GIMLET_MPI_PC "${MPI_PC}")
set(GIMLET_HDF5_PC "${HDF5_PC}")
set(GIMLET_PETSC_PC "${PETSC_PC}")
configure_file("${PC_IN}" "${PC_OUT}" @ONLY)
