#pragma once
#include <Kokkos_Macros.hpp>

#include <string>

namespace mpmflow {

// The git commit the sources were at when this binary was built (`git describe --always --dirty`,
// "-dirty" for uncommitted changes), or "unknown commit" outside a git checkout. Defined in a
// source file that every build rewrites when the commit changed (cmake/MpmflowBuildCommit.cmake).
const char* build_commit();

// "mpmflow <version> (<commit>)": the banner's first words, and what wrote a snapshot or a
// checkpoint (their attribute mpmflow_build).
inline std::string build_identity() { return std::string("mpmflow ") + MPMFLOW_VERSION + " (" + build_commit() + ")"; }

// The Kokkos this binary was compiled against, "3.4.1" (KOKKOS_VERSION is major * 10000 + minor *
// 100 + patch): the banner's, and the benchmarks' context.
inline std::string kokkos_version() {
  constexpr int v = KOKKOS_VERSION;
  return std::to_string(v / 10000) + "." + std::to_string(v / 100 % 100) + "." + std::to_string(v % 100);
}

// The host compiler that compiled this file, "GCC 12.2.0" (under nvcc_wrapper, the compiler nvcc
// hands the host code to): the benchmarks' context, since the same commit runs at another pace with
// another compiler (clang 14 ran the step 0.8 times as fast: docs/performance_history.md).
inline std::string host_compiler() {
#if defined(__clang__)
  return std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
  return std::string("GCC ") + __VERSION__;
#else
  return "an unnamed compiler";
#endif
}

}  // namespace mpmflow
