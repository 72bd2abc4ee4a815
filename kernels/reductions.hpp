#pragma once
// Parallel reductions over particles that are not plain BLAS-1 operations.
#include "kernels/types.hpp"

namespace mpmflow {

// Where an array reduction (a functor with value_type = double[] and value_count) puts its totals:
// host memory of the caller's (Kokkos 4 takes no raw pointer there, Kokkos 3.4 and 4 both a View).
using HostTotals = Kokkos::View<double*, Kokkos::HostSpace, Kokkos::MemoryTraits<Kokkos::Unmanaged>>;

// The number of particles for which predicate(p) holds.
template <class ParticlePredicate>
index_t count_particles(const char* label, index_t num_particles, const ParticlePredicate& pred) {
  index_t count = 0;
  Kokkos::parallel_reduce(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, num_particles),
      KOKKOS_LAMBDA(const index_t p, index_t& local) { local += pred(p) ? 1 : 0; }, count);
  return count;
}

}  // namespace mpmflow
