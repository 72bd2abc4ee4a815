# cmake --install: the mpmflow binary; the tools, the cases and their schema under
# share/mpmflow; the core library with its headers and a package configuration, so that
#   find_package(mpmflow) ... target_link_libraries(app PRIVATE mpmflow::core)
# builds against the solver, and mpmflow::mpmflow names the executable.
include(CMakePackageConfigHelpers)

# The installed binary keeps the run paths of the libraries it was linked with; CMake leaves out
# those inside the project, such as the Kokkos that setup.sh builds into .deps/install.
set_target_properties(mpmflow PROPERTIES INSTALL_RPATH_USE_LINK_PATH TRUE)
if(Kokkos_DIR)
  get_filename_component(mpmflow_kokkos_library_dir "${Kokkos_DIR}/../.." ABSOLUTE)
  set_property(TARGET mpmflow APPEND PROPERTY INSTALL_RPATH "${mpmflow_kokkos_library_dir}")
endif()
install(TARGETS mpmflow EXPORT mpmflowTargets RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS mpmflow_core mpmflow_dependencies EXPORT mpmflowTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/src/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/mpmflow
        FILES_MATCHING PATTERN "*.hpp")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/kernels/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/mpmflow/kernels
        FILES_MATCHING PATTERN "*.hpp")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/cases/ DESTINATION ${CMAKE_INSTALL_DATADIR}/mpmflow/cases)
install(PROGRAMS ${PROJECT_SOURCE_DIR}/tools/mpmflow_plot.py ${PROJECT_SOURCE_DIR}/tools/compare_outputs.py
                 ${PROJECT_SOURCE_DIR}/tools/naca4.py
        DESTINATION ${CMAKE_INSTALL_DATADIR}/mpmflow/tools)

# A Kokkos (and Kokkos Kernels) built with the project from a source tree goes into the prefix
# too: the installed core links it, and the package configuration finds it there. (Its build
# directory is EXCLUDE_FROM_ALL, which leaves its install rules out of the project's: they are run
# here.)
foreach(mpmflow_in_tree_dir IN ITEMS "${MPMFLOW_KOKKOS_BINARY_DIR}" "${MPMFLOW_KOKKOS_KERNELS_BINARY_DIR}")
  if(mpmflow_in_tree_dir)
    install(CODE "include(\"${mpmflow_in_tree_dir}/cmake_install.cmake\")")
  endif()
endforeach()

set(MPMFLOW_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/mpmflow)
install(EXPORT mpmflowTargets NAMESPACE mpmflow:: DESTINATION ${MPMFLOW_CMAKE_DIR})
# mpmflow_dependencies is exported as mpmflow::mpmflow_dependencies; mpmflow::core is the library.
set_target_properties(mpmflow_core PROPERTIES EXPORT_NAME core)

# What the configuration finds again: the Kokkos (and Kokkos Kernels) this build used, and the
# other packages the core's interface names.
set(MPMFLOW_CONFIG_KOKKOS_DIR "${Kokkos_DIR}")
set(MPMFLOW_CONFIG_KOKKOS_KERNELS_DIR "${KokkosKernels_DIR}")
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/mpmflowConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/mpmflowConfig.cmake INSTALL_DESTINATION ${MPMFLOW_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/mpmflowConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/mpmflowConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/mpmflowConfigVersion.cmake
        DESTINATION ${MPMFLOW_CMAKE_DIR})
