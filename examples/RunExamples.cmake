# ctest driver (tests/CMakeLists.txt: examples_build_and_stand): installs the build tree
# into PREFIX, builds every example in examples/ against it with find_package(dynfilter)
# (each in its own build directory, as a user would) and runs it on the human figure and
# the squat. Each example exits 0 only when the figure stood through the squat.
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX}
                RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "install failed")
endif()
foreach(example IN LISTS EXAMPLES)
  set(build ${WORK_DIR}/${example})
  execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/${example} -B ${build}
                          -DCMAKE_PREFIX_PATH=${PREFIX} -DCMAKE_BUILD_TYPE=Release
                  RESULT_VARIABLE rc OUTPUT_QUIET)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${example}: configure against the installed package failed")
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} --build ${build} RESULT_VARIABLE rc OUTPUT_QUIET)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${example}: build failed")
  endif()
  foreach(mode paper qp)
    execute_process(COMMAND ${build}/${example} ${PREFIX}/share/dynfilter/models/human_figure.urdf
                            ${SOURCE_DIR}/data/squat_reference.csv --mode ${mode}
                    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
    message(STATUS "${out}${err}")
    if(NOT rc EQUAL 0 OR NOT out MATCHES "STOOD")
      message(FATAL_ERROR "${example} --mode ${mode}: the figure did not stand (exit ${rc})")
    endif()
  endforeach()
endforeach()
