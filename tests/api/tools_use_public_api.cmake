# The command line uses only the public API: every project header a file in
# tools/ includes is either one of its own (no directory) or tetlod/tetlod.hpp.
file(GLOB sources "${TOOLS_DIR}/*.cpp" "${TOOLS_DIR}/*.hpp")
foreach(f ${sources})
  file(STRINGS "${f}" includes REGEX "^#include \"tetlod/")
  foreach(line ${includes})
    if(NOT line STREQUAL "#include \"tetlod/tetlod.hpp\"")
      message(FATAL_ERROR "${f}: ${line}: tools/ may include only \"tetlod/tetlod.hpp\"")
    endif()
  endforeach()
endforeach()
