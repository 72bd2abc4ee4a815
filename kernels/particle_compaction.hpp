#pragma once
// Removing particles from the particle arrays in a deterministic order: after migration (the
// particles that left for another rank) and at open sides of the domain (those that left it).
// The holes the removed particles leave below the new count are filled by the last staying
// particles, both in index order: the result is the same on any thread count.
#include <string>

#include "kernels/types.hpp"

namespace mpmflow {

// Indices p in [first, last) with keep(p) true, in increasing order.
template <class Predicate>
IndexView select_indices(const char* label, index_t first, index_t last, const Predicate& keep) {
  index_t count = 0;
  Kokkos::parallel_reduce(
      label, Kokkos::RangePolicy<ExecutionSpace>(first, last),
      KOKKOS_LAMBDA(const index_t p, index_t& n) { n += keep(p) ? 1 : 0; }, count);
  IndexView selected(std::string(label), static_cast<size_t>(count));
  if (count == 0) return selected;
  Kokkos::parallel_scan(
      label, Kokkos::RangePolicy<ExecutionSpace>(first, last),
      KOKKOS_LAMBDA(const index_t p, index_t& offset, const bool final) {
        if (keep(p)) {
          if (final) selected(offset) = p;
          ++offset;
        }
      });
  return selected;
}

// field(holes(k)) = field(fillers(k)) for k in [0, count). (A named function, not a lambda in the
// caller: nvcc does not allow a device lambda inside the generic lambdas that visit the fields.)
template <class FieldView>
void fill_holes(const FieldView& field, const IndexView& holes, const IndexView& fillers, index_t count) {
  Kokkos::parallel_for(
      "particle_fill_holes", Kokkos::RangePolicy<ExecutionSpace>(0, count),
      KOKKOS_LAMBDA(const index_t k) { field(holes(k)) = field(fillers(k)); });
}

// The same, listed in `buffer` (kept by the caller from call to call, grown here where it is too
// short) in one scan that also counts them: for selections made every step, a pass over the
// particles fewer than counting first. Returns the first `count` entries of `buffer`.
template <class Predicate>
IndexView select_indices(const char* label, index_t first, index_t last, const Predicate& keep, IndexView& buffer) {
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
    buffer = IndexView(std::string(label), static_cast<size_t>(count + count / 4));
  }
  return Kokkos::subview(buffer, std::make_pair(index_t(0), count));
}

// The hole filling that packs the staying particles of [0, n) into [0, staying): the removed
// particles below `staying` (the holes) take the staying particles at and above it (the fillers),
// both in index order. `removed` lists the removed particles in increasing order, and
// `removed_at(p)` tells whether p is one of them. Apply it with fill_holes on every field.
struct HoleFilling {
  index_t staying = 0;  // the new count
  IndexView holes, fillers;
  index_t count = 0;    // holes to fill
};
template <class IsRemoved>
HoleFilling plan_hole_filling(index_t n, const IndexView& removed, const IsRemoved& removed_at) {
  HoleFilling plan;
  plan.staying = n - static_cast<index_t>(removed.extent(0));
  plan.holes = removed;
  plan.fillers = select_indices(
      "particle_hole_fillers", plan.staying, n, KOKKOS_LAMBDA(const index_t p) { return !removed_at(p); });
  plan.count = static_cast<index_t>(plan.fillers.extent(0));  // = removed particles below `staying`
  return plan;
}

}  // namespace mpmflow
