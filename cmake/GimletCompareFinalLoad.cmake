# cmake -DREFERENCE=<csv> -DRUN=<csv> -DTOL=<relative> -P GimletCompareFinalLoad.cmake
#
# Compares the load (the column load_n_per_m) on the last row of two
# nanoindentation.csv files written by examples-c/wedge_indentation: fails
# unless |load(RUN) / load(REFERENCE) - 1| <= TOL. Used by the ctest that
# holds the main job under stick (mu = inf) against the same run at a large
# finite mu (tests/CMakeLists.txt).
foreach(var REFERENCE RUN TOL)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "GimletCompareFinalLoad: ${var} is not set")
  endif()
endforeach()

function(final_load file out)
  if(NOT EXISTS "${file}")
    message(FATAL_ERROR "GimletCompareFinalLoad: ${file} does not exist")
  endif()
  file(STRINGS "${file}" lines)
  list(GET lines 0 header)
  string(REPLACE "," ";" names "${header}")
  list(FIND names "load_n_per_m" col)
  if(col LESS 0)
    message(FATAL_ERROR "GimletCompareFinalLoad: ${file} has no column load_n_per_m")
  endif()
  list(LENGTH lines n)
  if(n LESS 2)
    message(FATAL_ERROR "GimletCompareFinalLoad: ${file} has no data row")
  endif()
  math(EXPR last "${n} - 1")
  list(GET lines ${last} row)
  string(REPLACE "," ";" values "${row}")
  list(GET values ${col} v)
  set(${out} "${v}" PARENT_SCOPE)
endfunction()

final_load("${REFERENCE}" ref)
final_load("${RUN}" run)
# CMake's math() is integer-only: awk forms the relative deviation and
# exits non-zero when it exceeds the bound.
execute_process(
  COMMAND awk "BEGIN { r = ${run} / ${ref} - 1; if (r < 0) r = -r; printf \"%.9f\", r; exit !(r <= ${TOL}) }"
  OUTPUT_VARIABLE dev RESULT_VARIABLE within)
if(dev STREQUAL "")
  message(FATAL_ERROR "GimletCompareFinalLoad: could not compare ${run} with ${ref}")
endif()
message(STATUS "final load ${run} N/m against the reference's ${ref} N/m: relative deviation ${dev} (bound ${TOL})")
if(NOT within EQUAL 0)
  message(FATAL_ERROR "the final load ${run} N/m deviates from the reference's ${ref} N/m by ${dev}, beyond ${TOL}")
endif()
