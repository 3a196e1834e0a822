# Regenerates the human figure with default parameters and compares it with models/.
file(MAKE_DIRECTORY ${OUT})
execute_process(COMMAND ${PYTHON} ${SRC}/models/generate_human_figure.py
                        -o ${OUT}/human_figure.urdf --metadata ${OUT}/human_figure.json
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "generate_human_figure.py failed (${rc})")
endif()
foreach(f human_figure.urdf human_figure.json)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/${f} ${SRC}/models/${f}
                  RESULT_VARIABLE diff)
  if(NOT diff EQUAL 0)
    message(FATAL_ERROR "models/${f} differs from what the generator makes; regenerate it")
  endif()
endforeach()
