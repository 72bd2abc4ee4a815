#pragma once
// Basic types shared by every layer: the real type, the execution/memory spaces chosen at
// configure time, and the View aliases. Grid and particle state are structure-of-arrays Views in
// LayoutLeft (each field, or each component column, contiguous), so the same access pattern
// coalesces on GPUs and vectorises on CPUs.
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Kokkos_Core.hpp>

// Before a loop whose iterations are independent (the lanes of a stencil batch): asks the compiler
// to vectorise it. Only where OpenMP is on (its simd directive): GCC leaves these loops scalar on
// its own; elsewhere, and in device code, it is nothing.
#if defined(_OPENMP) && !defined(__CUDA_ARCH__) && !defined(__HIP_DEVICE_COMPILE__)
#define MPMFLOW_VECTORISE _Pragma("omp simd")
#else
#define MPMFLOW_VECTORISE
#endif

namespace mpmflow {

#ifdef MPMFLOW_SINGLE_PRECISION
using real_t = float;
#else
using real_t = double;
#endif

using ExecutionSpace = Kokkos::DefaultExecutionSpace;
using MemorySpace = ExecutionSpace::memory_space;
using DeviceType = Kokkos::Device<ExecutionSpace, MemorySpace>;

// Which code paths the kernels take: the CPUs' where the memory is the host's (vector lanes over
// blocks of indices, tiles that threads walk, a counting sort, duplicated or coloured P2G; the
// host reading the Views themselves), the GPUs' elsewhere (one index a thread, the sorted P2G
// gathered by blocks of nodes, a bin sort, atomics; the host reading mirrors, copied to and from
// the device). A build configured with MPMFLOW_GPU_CODE_PATHS_ON_HOST (the `gpu-paths` presets)
// takes the GPUs' paths on the host, and gives every host mirror memory of its own, as a GPU's
// has: so the code only a GPU build runs is run by the tests on CPUs, and a copy between a View
// and its mirror that is missing shows there.
#ifdef MPMFLOW_GPU_CODE_PATHS_ON_HOST
inline constexpr bool gpu_code_paths_on_host = true;
#else
inline constexpr bool gpu_code_paths_on_host = false;
#endif
inline constexpr bool cpu_code_paths = std::is_same<MemorySpace, Kokkos::HostSpace>::value && !gpu_code_paths_on_host;
// Whether the host may read and write the Views themselves (else through mirrors).
inline constexpr bool host_uses_views_directly =
    Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible && !gpu_code_paths_on_host;

// A host mirror of `view`: the View itself where the host may use it directly (Kokkos'
// create_mirror_view), else memory of its own (create_mirror).
template <class ViewType>
typename ViewType::HostMirror host_mirror(const ViewType& view) {
  if constexpr (gpu_code_paths_on_host)
    return Kokkos::create_mirror(view);
  else
    return Kokkos::create_mirror_view(view);
}

// Node and particle indices. 32 bits address 2^31 particles per rank, far beyond one GPU's memory.
using index_t = int;
using particle_id_t = std::int64_t;

using RealView = Kokkos::View<real_t*, Kokkos::LayoutLeft, DeviceType>;
using IndexView = Kokkos::View<index_t*, Kokkos::LayoutLeft, DeviceType>;
using ParticleIdView = Kokkos::View<particle_id_t*, Kokkos::LayoutLeft, DeviceType>;
// Several node fields side by side: (node, component), each component column contiguous.
using NodeFieldsView = Kokkos::View<real_t**, Kokkos::LayoutLeft, DeviceType>;

// A list of indices made on the host (nodes, particles), as a View of the execution space.
inline IndexView to_device_indices(const char* label, const std::vector<index_t>& host) {
  IndexView device(std::string(label), host.size());
  const auto mirror = host_mirror(device);
  std::copy(host.begin(), host.end(), mirror.data());
  Kokkos::deep_copy(device, mirror);
  return device;
}

// The capacity a list kept from call to call (KeptBuffer, the selections' buffers in
// kernels/particle_compaction.hpp) is made again with where it must hold `needed` entries and has
// room for `have`: a quarter to spare, at least twice what it had, and at least kept_list_minimum
// entries. (Grown by a quarter alone, the lists of splitting and merging, whose counts rise a
// little every step as a wake forms, were made again 107 times in the linear Mach 3 cylinder's first
// 300 steps: on a GPU each an allocation and a free that may wait for the device. Doubling makes the
// growths logarithmic in the counts' range, and the floor skips the small sizes: 4 or 8 KiB a list.)
inline constexpr size_t kept_list_minimum = 1024;
inline size_t grown_capacity(size_t needed, size_t have) {
  const size_t with_spare = needed + needed / 4, doubled = 2 * have;
  const size_t larger = with_spare > doubled ? with_spare : doubled;
  return larger > kept_list_minimum ? larger : kept_list_minimum;
}

// A View kept from call to call for work done every step (a migration's buffers, splitting's new
// ids), with its host mirror (host_mirror: the View itself where the host may use it): on a GPU an
// allocation costs more than the kernels of such a step, and a free may wait for the device.
// hold(n) makes it again where it has fewer than n entries (grown_capacity), or where n is under a
// quarter of them, less the floor (after a rebalancing moved many particles, the steps' few do not
// keep that memory for the rest of the run: made again with a quarter to spare); part(n) and
// host_part(n) are its first n entries. Not initialised: each use writes the entries it reads.
template <class ViewType>
struct KeptBuffer {
  ViewType device;
  typename ViewType::HostMirror host;
  void hold(size_t n, const char* label) {
    const size_t have = device.extent(0);
    if (have >= n && have <= 4 * n + kept_list_minimum) return;
    const size_t capacity = have < n ? grown_capacity(n, have) : grown_capacity(n, 0);
    device = ViewType(Kokkos::view_alloc(std::string(label), Kokkos::WithoutInitializing), capacity);
    host = host_mirror(device);
  }
  ViewType part(size_t n) const { return Kokkos::subview(device, std::make_pair(size_t(0), n)); }
  typename ViewType::HostMirror host_part(size_t n) const {
    return Kokkos::subview(host, std::make_pair(size_t(0), n));
  }
};

// Whether a run reorders the particle arrays by cell as it goes (numerics/reorder_interval > 0), or
// leaves them in the order they drift into: the CPU walk's tiles are chosen for it
// (kernels/transfer_kernels.hpp, walk_tile_for).
enum class ParticleOrder { reordered_by_cell, never_reordered };

// The first index of part k of `parts` consecutive, nearly equal parts of [0, n): a thread's share
// of the particles where each thread walks its own range (the cell order's chunks, the selections').
KOKKOS_INLINE_FUNCTION index_t range_part_begin(index_t n, index_t parts, index_t k) {
  return static_cast<index_t>((static_cast<std::int64_t>(n) * k) / parts);
}

}  // namespace mpmflow
