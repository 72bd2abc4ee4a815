// GoogleTest main for the MPI unit tests: MPI and Kokkos live for the whole program, and every
// rank runs every test (the tests use EXPECT only, never ASSERT, so that no rank leaves a test
// early and the others wait in a collective call). mpirun's exit status is non-zero when any
// rank's is.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cstdlib>

#include <Kokkos_Core.hpp>

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  int status = 0;
  if (::testing::GTEST_FLAG(list_tests)) {
    status = RUN_ALL_TESTS();
  } else {
    setenv("OMP_PROC_BIND", "false", /*overwrite=*/0);
    Kokkos::initialize(argc, argv);
    status = RUN_ALL_TESTS();
    Kokkos::finalize();
  }
  MPI_Finalize();
  return status;
}
