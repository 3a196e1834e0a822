# Fails when a file under CORE_DIR includes anything but Eigen, the C++ standard
# library or core's own headers. Run by the dynfilter_core_include_guard target.
file(GLOB_RECURSE core_files "${CORE_DIR}/*.hpp" "${CORE_DIR}/*.cpp" "${CORE_DIR}/*.h")
set(violations "")
foreach(f IN LISTS core_files)
  file(STRINGS "${f}" lines REGEX "^[ \t]*#[ \t]*include")
  foreach(line IN LISTS lines)
    string(REGEX MATCH "[<\"]([^>\"]+)[>\"]" _m "${line}")
    set(header "${CMAKE_MATCH_1}")
    if(header MATCHES "^Eigen/" OR header MATCHES "^dynfilter/core/"
       OR header MATCHES "^[a-z_]+$")   # standard library headers: <vector>, <cmath>, ...
      continue()
    endif()
    string(APPEND violations "\n  ${f}: ${line}")
  endforeach()
endforeach()
if(violations)
  message(FATAL_ERROR "core/ must depend on Eigen and the standard library only; "
                      "offending includes:${violations}")
endif()
