#pragma once
// Removing particles from the particle arrays in a deterministic order: after migration (the
// particles that left for another rank) and at open sides of the domain (those that left it).
// The holes the removed particles leave below the new count are filled by the last staying
// particles, both in index order: the result is the same on any thread count.
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "kernels/types.hpp"

namespace mpmflow {

// Indices p in [first, last) with keep(p) true, in increasing order, listed in `buffer` (kept by the
// caller from call to call, grown here where it is too short: the selections are made every step,
// and a step allocates nothing) in one scan that also counts them, not a count and then a list: a
// pass over the particles fewer. Returns the first `count` entries of `buffer`. Where the particles
// are in host memory, select_indices_in_parts instead.
template <class Predicate>
IndexView select_indices_by_scan(const char* label, index_t first, index_t last, const Predicate& keep,
                                 IndexView& buffer) {
  index_t count = 0;
  for (;;) {
    const IndexView selected = buffer;
    const index_t capacity = static_cast<index_t>(selected.extent(0));
    Kokkos::parallel_scan(
        label, Kokkos::RangePolicy<ExecutionSpace>(first, last),
        KOKKOS_LAMBDA(const index_t p, index_t& offset, const bool final) {
          if (keep(p)) {
            if (final && offset < capacity) selected(offset) = p;
            ++offset;
          }
        },
        count);
    if (count <= capacity) break;
    buffer = IndexView(std::string(label), grown_capacity(static_cast<size_t>(count), selected.extent(0)));
  }
  return Kokkos::subview(buffer, std::make_pair(index_t(0), count));
}

// On CPUs, with the predicate evaluated once per particle: a scan evaluates it twice (Kokkos'
// parallel_scan on CPUs runs each thread's range once to count, once to write), reading what it
// reads twice. Here each of `parts` consecutive ranges of particles lists its own into its part of
// `buffer`, and the parts are then moved together on the host (the selections are small). Where a
// part is too short, the buffer grows and the pass runs again. The same list, in increasing order,
// for any number of parts (threads).
template <class Predicate>
IndexView select_indices_in_parts(const char* label, index_t first, index_t last, const Predicate& keep,
                                  IndexView& buffer) {
  const index_t parts = ExecutionSpace().concurrency();
  const index_t n = last - first;
  std::vector<index_t> counts(static_cast<size_t>(parts));
  index_t* const part_count = counts.data();
  for (;;) {
    const IndexView selected = buffer;
    const index_t part_size = static_cast<index_t>(selected.extent(0)) / parts;
    Kokkos::parallel_for(
        label, Kokkos::RangePolicy<ExecutionSpace>(0, parts), KOKKOS_LAMBDA(const index_t k) {
          // (The bounds in locals: the loop's stores might alias the captured values, and
          // range_part_begin divides.)
          const index_t begin = first + range_part_begin(n, parts, k), end = first + range_part_begin(n, parts, k + 1);
          index_t* const out = selected.data() + part_size * k;
          index_t count = 0;
          for (index_t p = begin; p < end; ++p)
            if (keep(p)) {
              if (count < part_size) out[count] = p;
              ++count;
            }
          part_count[k] = count;
        });
    index_t largest = 0;
    for (index_t k = 0; k < parts; ++k) largest = part_count[k] > largest ? part_count[k] : largest;
    if (largest <= part_size) break;
    // (Each part at least a quarter above the largest: grown_capacity of all the parts' largest.)
    buffer = IndexView(std::string(label), grown_capacity(static_cast<size_t>(parts * largest), selected.extent(0)));
  }
  // Part k to the end of parts 0 .. k - 1: to the left (or where it is), in order, so that no part
  // is overwritten before it moves.
  const index_t part_size = static_cast<index_t>(buffer.extent(0)) / parts;
  index_t count = 0;
  for (index_t k = 0; k < parts; ++k) {
    // (An empty part is skipped: the buffer may hold nothing, and memmove's pointers may not be null
    // even for no bytes; UBSan flagged it.)
    if (part_count[k] == 0) continue;
    std::memmove(buffer.data() + count, buffer.data() + part_size * k, sizeof(index_t) * part_count[k]);
    count += part_count[k];
  }
  return Kokkos::subview(buffer, std::make_pair(index_t(0), count));
}

template <class Predicate>
IndexView select_indices(const char* label, index_t first, index_t last, const Predicate& keep, IndexView& buffer) {
  if constexpr (cpu_code_paths)
    return select_indices_in_parts(label, first, last, keep, buffer);
  else
    return select_indices_by_scan(label, first, last, keep, buffer);
}

// The hole filling that packs the staying particles of [0, n) into [0, staying): the removed
// particles below `staying` (the holes) take the staying particles at and above it (the fillers),
// both in index order. `removed` lists the removed particles in increasing order, and
// `removed_at(p)` tells whether p is one of them. Apply it to every field: particle holes(k) becomes
// a copy of particle fillers(k) (copy_particles, src/particles.hpp).
struct HoleFilling {
  index_t staying = 0;  // the new count
  IndexView holes, fillers;
  index_t count = 0;    // holes to fill
};
// The fillers are listed in `buffer`, kept by the caller from call to call and grown here where it
// is too short (hole fillings are made every step: open sides, migration, merging), so that a step
// allocates nothing and, on CPUs, passes once over the particles above `staying`.
template <class IsRemoved>
HoleFilling plan_hole_filling(index_t n, const IndexView& removed, const IsRemoved& removed_at, IndexView& buffer) {
  HoleFilling plan;
  plan.staying = n - static_cast<index_t>(removed.extent(0));
  plan.holes = removed;
  plan.fillers = select_indices(
      "particle_hole_fillers", plan.staying, n, KOKKOS_LAMBDA(const index_t p) { return !removed_at(p); }, buffer);
  plan.count = static_cast<index_t>(plan.fillers.extent(0));  // = removed particles below `staying`
  return plan;
}

}  // namespace mpmflow
