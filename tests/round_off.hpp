#pragma once
// Tolerances on round-off for the build's reals (real_t, kernels/types.hpp: double, or float with
// MPMFLOW_SINGLE_PRECISION).
#include <limits>

#include "kernels/types.hpp"

namespace mpmflow {

// A bound on round-off written for double, for the build's reals: scaled by the ratio of their
// epsilon to double's (1 in a double build, 2^29 in single precision), so that a check of
// round-off holds in either build and is not loosened in double. Only for bounds on round-off
// (a kernel against its reference, a sum that is zero but for rounding): a bound on a method's
// error is the method's whatever the precision.
constexpr double round_off(double at_double) {
  return at_double * (static_cast<double>(std::numeric_limits<real_t>::epsilon()) /
                      std::numeric_limits<double>::epsilon());
}

// A bound on round-off that a run grows (a difference of summation order, amplified step after
// step), given for each precision: double's scaled by the epsilons' ratio would be too loose to
// catch a fault (1e-9 -> 0.54), so the single-precision bound is its own, written beside what that
// build was seen to give.
constexpr double per_precision(double in_double, double in_single) {
  return sizeof(real_t) == sizeof(double) ? in_double : in_single;
}

}  // namespace mpmflow
