#pragma once
// Math and numeric limits for code that runs on the device. std:: functions are host functions
// under nvcc; Kokkos provides device-callable ones, under Kokkos::Experimental in Kokkos 3.x and
// under Kokkos:: from Kokkos 4.0 on (where the Experimental spellings are deprecated code).
#include "kernels/types.hpp"

namespace mpmflow {

KOKKOS_INLINE_FUNCTION real_t square_root(real_t x) {
#if KOKKOS_VERSION >= 40000
  return Kokkos::sqrt(x);
#else
  return Kokkos::Experimental::sqrt(x);
#endif
}

KOKKOS_INLINE_FUNCTION real_t absolute_value(real_t x) {
#if KOKKOS_VERSION >= 40000
  return Kokkos::fabs(x);
#else
  return Kokkos::Experimental::fabs(x);
#endif
}

// min(x, 1) as (x + 1 - |x - 1|) / 2, without a select: GCC kept the particle updates of a batch
// scalar with a few selects more in them (volume_corrected_density), and vectorises this.
KOKKOS_INLINE_FUNCTION real_t at_most_one(real_t x) { return real_t(0.5) * (x + 1 - absolute_value(x - 1)); }

KOKKOS_INLINE_FUNCTION real_t power(real_t x, real_t y) {
#if KOKKOS_VERSION >= 40000
  return Kokkos::pow(x, y);
#else
  return Kokkos::Experimental::pow(x, y);
#endif
}

// The largest finite real_t (Kokkos' numeric traits: the same spelling in Kokkos 3.4 and 4.x).
constexpr real_t largest_real = Kokkos::Experimental::finite_max<real_t>::value;
// The spacing of real_t's values at 1 (the same traits).
constexpr real_t real_epsilon = Kokkos::Experimental::epsilon<real_t>::value;
// How close two values that mirror images of a flow compute in different orders (a node's sums add
// a cell's particles in an order they do not share) must be, relatively, to count as equal where a
// decision hangs on it (splitting in four or in two, merging's ties): 1e-9, far above double's
// round-off and below what physics cares about, or 1024 units of the last place where that is more
// (single precision: 1.2e-4; with 1e-9, below its epsilon, a tie there was an exact equality, and
// mirror images split and paired otherwise: the quadrants' difference from their mirror image at
// t = 0.2 was 6.3e-4, 4.5e-5 now, Physics.MirrorSymmetry).
constexpr real_t mirror_tie_tolerance = real_t(1e-9) > 1024 * real_epsilon ? real_t(1e-9) : 1024 * real_epsilon;

}  // namespace mpmflow
