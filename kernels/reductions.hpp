#pragma once
// Parallel reductions over particles that are not plain BLAS-1 operations.
#include <cmath>

#include "kernels/types.hpp"

namespace mpmflow {

// max_p F(p) for a functor real_t F(index_t p); returns `floor` when there are no particles.
template <class ParticleFunctor>
real_t max_over_particles(const char* label, index_t num_particles, const ParticleFunctor& f,
                          real_t floor = 0) {
  real_t result = floor;
  Kokkos::parallel_reduce(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, num_particles),
      KOKKOS_LAMBDA(const index_t p, real_t& local_max) {
        const real_t value = f(p);
        if (value > local_max) local_max = value;
      },
      Kokkos::Max<real_t>(result));
  return result > floor ? result : floor;
}

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
