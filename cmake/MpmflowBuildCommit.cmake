# Run at every build (cmake -P, from the mpmflow_build_commit target in src/CMakeLists.txt): writes
# OUTPUT, a source file defining mpmflow::build_commit(), the git commit the sources are at
# (`git describe --always --dirty`). At every build, not at configure time: a build directory
# configured once and rebuilt after later commits would otherwise name the commit it was configured
# at. OUTPUT is replaced only when the commit changed, so that an unchanged tree rebuilds nothing.
#   -DSOURCE_DIR=<the project's sources> -DOUTPUT=<the file to write>
execute_process(COMMAND git describe --always --dirty
                WORKING_DIRECTORY "${SOURCE_DIR}"
                OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE
                RESULT_VARIABLE git_result ERROR_QUIET)
if(NOT git_result EQUAL 0 OR commit STREQUAL "")
  set(commit "unknown commit")  # not a git checkout (a source archive), or no git
endif()
string(CONCAT text "// Written by cmake/MpmflowBuildCommit.cmake at build time: do not edit.\n"
                   "namespace mpmflow {\n"
                   "const char* build_commit() { return \"${commit}\"; }\n"
                   "}  // namespace mpmflow\n")
if(EXISTS "${OUTPUT}")
  file(READ "${OUTPUT}" previous)
  if(previous STREQUAL text)
    return()
  endif()
endif()
file(WRITE "${OUTPUT}.tmp" "${text}")
file(RENAME "${OUTPUT}.tmp" "${OUTPUT}")
