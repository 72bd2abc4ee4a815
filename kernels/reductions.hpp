#pragma once
// Parallel reductions over particles that are not plain BLAS-1 operations.
#include "kernels/types.hpp"

#include <string>
#include <vector>

namespace mpmflow {

// Where an array reduction (a functor with value_type = double[] and value_count) puts its totals:
// host memory of the caller's (Kokkos 4 takes no raw pointer there, Kokkos 3.4 and 4 both a View).
using HostTotals = Kokkos::View<double*, Kokkos::HostSpace, Kokkos::MemoryTraits<Kokkos::Unmanaged>>;

// The totals[0 .. f.value_count) of an array reduction over i in [0, n): f is a Kokkos array
// reduction functor (value_type = double[], value_count, operator()(i, sums) adding index i's
// terms to sums), `totals` host memory. Two forms by name (the tests run both):
// - _in_fixed_chunks (CPUs): chunks of `chunk` indices, each summed in index order by one thread,
//   then the chunks' sums in chunk order on the host: an order fixed by n and chunk alone, so the
//   same bits on any number of threads. (Kokkos' OpenMP reduction sums each thread's share, then
//   the threads' sums: its totals change in their last bits with the thread count, and with them
//   a run's diagnostics.csv.) A chunk is a few hundred to a few thousand indices: enough chunks
//   to share among the threads, few enough that the host's pass over them costs nothing.
// - _in_kokkos (elsewhere): Kokkos' parallel_reduce, in Kokkos' order.
template <class Functor>
void sum_in_fixed_chunks(const char* label, index_t n, index_t chunk, const Functor& f, double* totals) {
  const index_t count = static_cast<index_t>(f.value_count);
  for (index_t c = 0; c < count; ++c) totals[c] = 0;
  if (n <= 0) return;
  const index_t chunks = (n + chunk - 1) / chunk;
  // Each chunk's sums, chunk by chunk: host memory where the execution space writes there (CPUs),
  // not a Kokkos allocation (the benchmark counts those a step); else (and on the GPU paths on the
  // host, which so run this form) the device's, copied back.
  std::vector<double> chunk_sums(static_cast<size_t>(chunks * count));
  double* all_sums = chunk_sums.data();
  Kokkos::View<double*, MemorySpace> device_sums;
  constexpr bool writes_host_memory =
      Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible && !gpu_code_paths_on_host;
  if constexpr (!writes_host_memory) {
    device_sums = Kokkos::View<double*, MemorySpace>(
        Kokkos::view_alloc(Kokkos::WithoutInitializing, std::string(label)), chunk_sums.size());
    all_sums = device_sums.data();
  }
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, chunks), KOKKOS_LAMBDA(const index_t k) {
        double* const sums = all_sums + k * count;
        for (index_t c = 0; c < count; ++c) sums[c] = 0;
        const index_t end = (k + 1) * chunk < n ? (k + 1) * chunk : n;
        for (index_t i = k * chunk; i < end; ++i) f(i, sums);
      });
  if constexpr (writes_host_memory)
    Kokkos::fence();
  else
    Kokkos::deep_copy(HostTotals(chunk_sums.data(), chunk_sums.size()), device_sums);
  for (index_t k = 0; k < chunks; ++k)
    for (index_t c = 0; c < count; ++c) totals[c] += chunk_sums[static_cast<size_t>(k * count + c)];
}
template <class Functor>
void sum_in_kokkos(const char* label, index_t n, const Functor& f, double* totals) {
  const size_t count = f.value_count;
  if (n <= 0) {
    for (size_t c = 0; c < count; ++c) totals[c] = 0;
    return;
  }
  Kokkos::parallel_reduce(label, Kokkos::RangePolicy<ExecutionSpace>(0, n), f, HostTotals(totals, count));
}
// The indices a chunk of sum_in_fixed_order (1024: 880 chunks for the 9e5 particles of the
// benchmark's 1e5 cells).
constexpr index_t fixed_order_chunk = 1024;
template <class Functor>
void sum_in_fixed_order(const char* label, index_t n, const Functor& f, double* totals) {
  if constexpr (cpu_code_paths)
    sum_in_fixed_chunks(label, n, fixed_order_chunk, f, totals);
  else
    sum_in_kokkos(label, n, f, totals);
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
