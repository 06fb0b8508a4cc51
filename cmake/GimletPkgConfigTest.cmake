# Script mode (cmake -P), run by the ctest test `consumer_pkgconfig`:
# builds the consumer program with nothing but
#   cc consumer.c $(pkg-config --cflags --libs gimlet)
# against the installed prefix, checks `pkg-config --modversion gimlet`, and
# runs the program under mpiexec -n 1.
#
# Inputs (-D): PKG_CONFIG, CC, PREFIX, LIBDIR, SOURCE, WORK_DIR, VERSION,
# MPIEXEC, NP_FLAG.

foreach(var PKG_CONFIG CC PREFIX LIBDIR SOURCE WORK_DIR VERSION MPIEXEC NP_FLAG)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "GimletPkgConfigTest.cmake: -D${var}=... is required")
  endif()
endforeach()

set(ENV{PKG_CONFIG_PATH} "${PREFIX}/${LIBDIR}/pkgconfig")

function(run_checked out_var)
  execute_process(COMMAND ${ARGN}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
    OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "`${cmd}` failed (${rc}):\n${out}\n${err}")
  endif()
  set(${out_var} "${out}" PARENT_SCOPE)
endfunction()

run_checked(modversion "${PKG_CONFIG}" --modversion gimlet)
if(NOT modversion STREQUAL VERSION)
  message(FATAL_ERROR "pkg-config --modversion gimlet is `${modversion}`, the build is ${VERSION}")
endif()
run_checked(flags "${PKG_CONFIG}" --cflags --libs gimlet)
message(STATUS "pkg-config --cflags --libs gimlet: ${flags}")
separate_arguments(flags UNIX_COMMAND "${flags}")

file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
set(exe "${WORK_DIR}/gimlet_consumer_pc")
run_checked(ignored "${CC}" "${SOURCE}" ${flags} -o "${exe}")

# No rpath in the flags: find the installed library like a user would.
set(ENV{LD_LIBRARY_PATH} "${PREFIX}/${LIBDIR}:$ENV{LD_LIBRARY_PATH}")
run_checked(out "${MPIEXEC}" ${NP_FLAG} 1 "${exe}")
message(STATUS "${out}")
