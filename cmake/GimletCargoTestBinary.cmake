# Script mode (cmake -P), run by a ctest fixture: builds one Rust integration
# test binary with cargo (release; a no-op when `cargo test --release` already
# built it) and copies it to OUTPUT, so that ctest can launch it under
# `mpiexec -n N` (MPI can be initialised once per process, so MPI tests run as
# their own programs, not as threads of the cargo test harness).
#
# Inputs (-D): CARGO, MANIFEST, TARGET_DIR, PACKAGE, TEST (the file name under
# tests/ without .rs), OUTPUT; optional: HDF5_DIR (given to hdf5-sys, as for
# the library build, so that a test of the gimlet package reuses its build),
# JOBS (cargo -j).

foreach(var CARGO MANIFEST TARGET_DIR PACKAGE TEST OUTPUT)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "GimletCargoTestBinary.cmake: -D${var}=... is required")
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
          ${CARGO} test --release -p ${PACKAGE} --test ${TEST} --no-run ${job_args}
          --manifest-path ${MANIFEST} --message-format=json-render-diagnostics
  RESULT_VARIABLE rc
  OUTPUT_VARIABLE json)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cargo could not build test `${TEST}` of ${PACKAGE} (exit ${rc})")
endif()

# One JSON message per line; the test's compiler-artifact names the binary.
set(exe "")
string(REPLACE "\n" ";" lines "${json}")
foreach(line IN LISTS lines)
  if(NOT line MATCHES "\"reason\":\"compiler-artifact\"")
    continue()
  endif()
  string(JSON name ERROR_VARIABLE e GET "${line}" target name)
  string(JSON kind ERROR_VARIABLE e GET "${line}" target kind 0)
  string(JSON path ERROR_VARIABLE e GET "${line}" executable)
  if(name STREQUAL TEST AND kind STREQUAL "test" AND path)
    set(exe "${path}")
  endif()
endforeach()
if(NOT exe)
  message(FATAL_ERROR "cargo reported no executable for test `${TEST}` of ${PACKAGE}")
endif()

get_filename_component(out_dir "${OUTPUT}" DIRECTORY)
file(MAKE_DIRECTORY "${out_dir}")
file(COPY_FILE "${exe}" "${OUTPUT}" ONLY_IF_DIFFERENT)
message(STATUS "${exe} -> ${OUTPUT}")
