# Finds (or builds from a source tree) the project's dependencies and defines
# mpmflow::dependencies, an interface target carrying them and the MPMFLOW_HAVE_* definitions.
add_library(mpmflow_dependencies INTERFACE)
add_library(mpmflow::dependencies ALIAS mpmflow_dependencies)
# mpi.h (ours or the one parallel HDF5 includes) must not drag in the removed MPI C++ bindings.
target_compile_definitions(mpmflow_dependencies INTERFACE OMPI_SKIP_MPICXX MPICH_SKIP_MPICXX)

# --- Kokkos: a source tree given at configure time, else an installed one (Kokkos_ROOT) --------
if(MPMFLOW_KOKKOS_SOURCE_DIR)
  message(STATUS "mpmflow: building Kokkos from ${MPMFLOW_KOKKOS_SOURCE_DIR}")
  set(MPMFLOW_KOKKOS_BINARY_DIR ${CMAKE_BINARY_DIR}/kokkos)  # (installed with the project: MpmflowInstall)
  add_subdirectory(${MPMFLOW_KOKKOS_SOURCE_DIR} ${MPMFLOW_KOKKOS_BINARY_DIR} EXCLUDE_FROM_ALL)
else()
  find_package(Kokkos REQUIRED)
endif()
target_link_libraries(mpmflow_dependencies INTERFACE Kokkos::kokkos)

# --- The host CPU's instruction set (a Kokkos configured with Kokkos_ARCH_* may add its own) -----
if(MPMFLOW_ARCH_NATIVE)
  include(CheckCXXCompilerFlag)
  check_cxx_compiler_flag(-march=native MPMFLOW_COMPILER_HAS_MARCH_NATIVE)
  if(NOT MPMFLOW_COMPILER_HAS_MARCH_NATIVE)
    message(FATAL_ERROR "mpmflow: MPMFLOW_ARCH_NATIVE=ON but ${CMAKE_CXX_COMPILER} does not accept -march=native")
  endif()
  target_compile_options(mpmflow_dependencies INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-march=native>)
endif()

# --- No errno from the maths library: the solver never reads it, and a sqrt that may set it (a
# library call on a negative argument) keeps the particle loops from vectorising. The results are
# the same bits.
include(CheckCXXCompilerFlag)
check_cxx_compiler_flag(-fno-math-errno MPMFLOW_COMPILER_HAS_NO_MATH_ERRNO)
if(MPMFLOW_COMPILER_HAS_NO_MATH_ERRNO)
  target_compile_options(mpmflow_dependencies INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-fno-math-errno>)
endif()
# --- No floating-point traps: the solver never enables them nor reads the exception flags. Without
# this GCC may not compute a floating-point operation on a path the source does not take, so a
# loop whose body has such a path stays scalar wherever the vector unit has no masks (the nearest
# node's offset, x - 1 on one side of a select; the GIMP stencils' clamp of the particle's
# half-length, which GCC turned into branches, each with its own copy of what follows). With AVX2
# (AMD Zen 3) the batched stencils of GIMP and B-splines, G2PD's particle updates and the blocks
# of for_each_index_in_blocks (the pressure relaxation's pass) did not vectorise, and the GIMP
# step ran at half its speed; with AVX-512, whose masks let GCC compute a lane's operation without
# its trap, it made no difference. The results are the same bits (docs/performance_history.md,
# "Floating-point traps").
check_cxx_compiler_flag(-fno-trapping-math MPMFLOW_COMPILER_HAS_NO_TRAPPING_MATH)
if(MPMFLOW_COMPILER_HAS_NO_TRAPPING_MATH)
  target_compile_options(mpmflow_dependencies INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-fno-trapping-math>)
endif()

# --- Kokkos Kernels (BLAS-1 diagnostics); optional so a minimal build needs Kokkos alone -----
if(MPMFLOW_KOKKOS_KERNELS_SOURCE_DIR)
  set(MPMFLOW_KOKKOS_KERNELS_BINARY_DIR ${CMAKE_BINARY_DIR}/kokkos-kernels)
  add_subdirectory(${MPMFLOW_KOKKOS_KERNELS_SOURCE_DIR} ${MPMFLOW_KOKKOS_KERNELS_BINARY_DIR} EXCLUDE_FROM_ALL)
  set(KokkosKernels_FOUND ON)
else()
  find_package(KokkosKernels QUIET)
endif()
if(KokkosKernels_FOUND)
  message(STATUS "mpmflow: Kokkos Kernels found: diagnostics use KokkosBlas (on CPUs its products; the sums go in fixed chunks there)")
  target_link_libraries(mpmflow_dependencies INTERFACE Kokkos::kokkoskernels)
  target_compile_definitions(mpmflow_dependencies INTERFACE MPMFLOW_HAVE_KOKKOS_KERNELS)
else()
  message(STATUS "mpmflow: Kokkos Kernels not found: diagnostics use plain Kokkos reductions")
endif()

find_package(nlohmann_json 3 REQUIRED)
# The command line (src/main.cpp only): Debian's libcli11-dev, header-only.
find_package(CLI11 2 REQUIRED)

if(MPMFLOW_ENABLE_MPI)
  find_package(MPI REQUIRED COMPONENTS C)
  target_link_libraries(mpmflow_dependencies INTERFACE MPI::MPI_C)
  target_compile_definitions(mpmflow_dependencies INTERFACE MPMFLOW_HAVE_MPI)
endif()

if(MPMFLOW_ENABLE_HDF5)
  # Debian's Open MPI build of HDF5 (libhdf5-openmpi-dev): prefer the parallel library.
  set(HDF5_PREFER_PARALLEL ON)
  find_package(HDF5 REQUIRED COMPONENTS C)
  target_include_directories(mpmflow_dependencies INTERFACE ${HDF5_INCLUDE_DIRS})
  target_link_libraries(mpmflow_dependencies INTERFACE ${HDF5_LIBRARIES})
  target_compile_definitions(mpmflow_dependencies INTERFACE MPMFLOW_HAVE_HDF5 ${HDF5_DEFINITIONS})
  if(HDF5_IS_PARALLEL)
    # The parallel hdf5.h includes mpi.h, whether or not mpmflow itself uses MPI.
    find_package(MPI REQUIRED COMPONENTS C)
    target_link_libraries(mpmflow_dependencies INTERFACE MPI::MPI_C)
  endif()
endif()

