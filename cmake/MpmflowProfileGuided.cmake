# Profile-guided optimisation of the core library (GCC), in two builds: one configured with
# MPMFLOW_PROFILE_GENERATE=DIR is instrumented, and its runs write their counts (.gcda files) into
# DIR; one configured with MPMFLOW_PROFILE_USE=DIR compiles the core with those counts.
# scripts/build_profiled.sh does both, with the training runs between (README, Benchmarks).
#
# Both builds strip their own build folder from the profile files' names
# (-fprofile-prefix-path), so that a profile made in one build folder serves another; their
# other flags must be the same (the presets `openmp-profile-training` and `openmp-profiled` both
# inherit `openmp`'s), or GCC finds the functions changed and ignores their counts.

function(mpmflow_profile_guided target generated_sources)
  if(NOT MPMFLOW_PROFILE_GENERATE AND NOT MPMFLOW_PROFILE_USE)
    return()
  endif()
  if(MPMFLOW_PROFILE_GENERATE AND MPMFLOW_PROFILE_USE)
    message(FATAL_ERROR "mpmflow: MPMFLOW_PROFILE_GENERATE and MPMFLOW_PROFILE_USE are both set; "
                        "expected one: the training build generates the profile, another build uses it")
  endif()
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    message(FATAL_ERROR "mpmflow: MPMFLOW_PROFILE_GENERATE / MPMFLOW_PROFILE_USE need GCC's -fprofile-generate "
                        "and -fprofile-use; the compiler is ${CMAKE_CXX_COMPILER_ID} (${CMAKE_CXX_COMPILER})")
  endif()
  set(strip_build_folder -fprofile-prefix-path=${CMAKE_BINARY_DIR})
  if(MPMFLOW_PROFILE_GENERATE)
    message(STATUS "mpmflow: ${target} instrumented for profile-guided optimisation; runs write to ${MPMFLOW_PROFILE_GENERATE}")
    # prefer-atomic: counts from several threads add up without being lost.
    target_compile_options(${target} PRIVATE -fprofile-generate=${MPMFLOW_PROFILE_GENERATE}
                                             -fprofile-update=prefer-atomic ${strip_build_folder})
    target_link_options(${target} PUBLIC -fprofile-generate)
  else()
    # A source's profile file is named after its object, the build folder stripped and '/' as '#'.
    # Each source depends on its own, so that a new training compiles it again, not only a change
    # of the source.
    file(RELATIVE_PATH target_folder ${CMAKE_BINARY_DIR} ${CMAKE_CURRENT_BINARY_DIR})
    string(REPLACE "/" "#" profile_prefix "${target_folder}/CMakeFiles/${target}.dir")
    get_target_property(sources ${target} SOURCES)
    set(profiled_sources 0)
    foreach(source IN LISTS sources)
      set(profile_file "${MPMFLOW_PROFILE_USE}/${profile_prefix}#${source}.gcda")
      if(EXISTS "${profile_file}")
        set_property(SOURCE ${source} TARGET_DIRECTORY ${target} APPEND PROPERTY OBJECT_DEPENDS "${profile_file}")
        math(EXPR profiled_sources "${profiled_sources} + 1")
      endif()
    endforeach()
    if(profiled_sources EQUAL 0)
      message(FATAL_ERROR "mpmflow: MPMFLOW_PROFILE_USE=${MPMFLOW_PROFILE_USE}: expected the ${target} profile "
                          "files (${profile_prefix}#SOURCE.gcda) that runs of a build configured with "
                          "MPMFLOW_PROFILE_GENERATE write there; none found. scripts/build_profiled.sh makes them.")
    endif()
    message(STATUS "mpmflow: ${target} optimised with the profile in ${MPMFLOW_PROFILE_USE} "
                   "(${profiled_sources} sources)")
    # -fprofile-partial-training: code the training did not run (other shapes, P2G strategies,
    # back-ends' paths) is optimised as without a profile, not for size as never-run code.
    # -Wno-error=coverage-mismatch: sources edited since the training still build (GCC warns that
    # the profile may be out of date and ignores it for the functions that changed); run
    # scripts/build_profiled.sh again to train anew.
    target_compile_options(${target} PRIVATE -fprofile-use=${MPMFLOW_PROFILE_USE} -fprofile-partial-training
                                             -Wno-error=coverage-mismatch ${strip_build_folder})
    # The generated sources (the git commit) lie in the build folder, so their functions' source
    # locations differ between the two builds: GCC would reject their counts as out of date. Their
    # counts are worth nothing; the mismatch is not reported for them.
    set_source_files_properties(${generated_sources} TARGET_DIRECTORY ${target} PROPERTIES COMPILE_OPTIONS
                                -Wno-coverage-mismatch)
  endif()
endfunction()
