#pragma once
// Loops over indices whose bodies run as vector lanes on CPUs: for_each_index_in_lanes (a body
// per index) for the passes over cells or particles that are not transfers (the relaxation, the
// cell map). The transfer kernels batch their particles the same way (transfer_kernels.hpp).
#include <type_traits>

#include "kernels/types.hpp"

namespace mpmflow {

// Indices a block: 32, four AVX-512 vectors of doubles (as a stencil batch's particles).
constexpr int index_block_size = 32;

// Runs body(i) for i in [0, n), where body(i) writes only what belongs to i (a cell's row, a
// particle's fields): on CPUs in blocks of index_block_size indices, each a loop marked for
// vectorisation (GCC keeps Kokkos' range loop scalar: it cannot tell that the iterations' View
// accesses are independent), so that the body's divisions and square roots run 8 at a time with
// AVX-512 (a body with a branch stays scalar: selects instead); one index per thread elsewhere
// (GPUs).
template <int L, class Body>
KOKKOS_FORCEINLINE_FUNCTION void run_block_in_lanes(const Body& body, index_t first, int count) {
  MPMFLOW_VECTORISE
  for (int l = 0; l < count; ++l) body(first + l);
}
template <class Body>
void for_each_index_in_blocks(const char* label, index_t n, const Body& body) {
  constexpr int L = index_block_size;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, (n + L - 1) / L), KOKKOS_LAMBDA(const index_t k) {
        run_block_in_lanes<L>(body, k * L, n - k * L < L ? static_cast<int>(n - k * L) : L);
      });
}
template <class Body>
void for_each_index_in_lanes(const char* label, index_t n, const Body& body) {
  if constexpr (std::is_same<MemorySpace, Kokkos::HostSpace>::value)
    for_each_index_in_blocks(label, n, body);
  else
    Kokkos::parallel_for(label, Kokkos::RangePolicy<ExecutionSpace>(0, n), body);
}

}  // namespace mpmflow
