// GoogleTest main for mpmflow: Kokkos lives for the whole test program.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>

#include <Kokkos_Core.hpp>

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  // Listing the tests (ctest's discovery) must print test names only, nothing from Kokkos.
  if (::testing::GTEST_FLAG(list_tests)) return RUN_ALL_TESTS();
  // Kokkos' own advice for unit tests; also silences its thread-binding warning.
  setenv("OMP_PROC_BIND", "false", /*overwrite=*/0);
  Kokkos::initialize(argc, argv);
  const int status = RUN_ALL_TESTS();
  Kokkos::finalize();
  return status;
}
