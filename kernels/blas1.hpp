#pragma once
// BLAS-1 on particle Views: Kokkos Kernels' KokkosBlas when the build has it (the default) and,
// for the sums, the Views hold doubles and the kernels take the GPUs' paths (below); else the same
// operations as plain Kokkos loops, so a minimal GPU build needs Kokkos alone.
#include "kernels/reductions.hpp"
#include "kernels/types.hpp"

#include <type_traits>

#ifdef MPMFLOW_HAVE_KOKKOS_KERNELS
#include <KokkosBlas1_dot.hpp>
#include <KokkosBlas1_mult.hpp>
#include <KokkosBlas1_sum.hpp>
#endif

namespace mpmflow {

// The sums below accumulate in double whatever real_t is: they make the conservation totals, which
// summed in float lost about 1e-4 of themselves (a single-precision build's coarse cylinder, 16 770
// particles: a mass-balance residual of 1.5e-4 after 454 steps, 1.8e-10 with the sums in double).
// KokkosBlas sums in the Views' own value type, so it serves where that is double; and on CPUs its
// sums change in their last bits with the thread count (Kokkos' OpenMP reduction sums each
// thread's share), so there the sums are taken in fixed chunks (sum_in_fixed_order), the same bits
// on any thread count, as a run's snapshots are with the sorted P2G.

// sum_k x_k and sum_k x_k y_k in double, in sum_in_fixed_order's order.
template <class XView>
struct SumInDouble {
  using value_type = double[];
  unsigned value_count = 1;  // (Kokkos' name: the length of an array reduction)
  XView x;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, value_type sum) const { sum[0] += x(k); }
};
template <class XView, class YView>
struct DotInDouble {
  using value_type = double[];
  unsigned value_count = 1;
  XView x;
  YView y;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, value_type sum) const {
    sum[0] += double(x(k)) * double(y(k));
  }
};
template <class XView>
double sum_in_double(const XView& x) {
  double result = 0;
  sum_in_fixed_order("blas_sum", static_cast<index_t>(x.extent(0)), SumInDouble<XView>{1, x}, &result);
  return result;
}
template <class XView, class YView>
double dot_in_double(const XView& x, const YView& y) {
  double result = 0;
  sum_in_fixed_order("blas_dot", static_cast<index_t>(x.extent(0)), DotInDouble<XView, YView>{1, x, y}, &result);
  return result;
}

#ifdef MPMFLOW_HAVE_KOKKOS_KERNELS
// Whether KokkosBlas takes the sums over View's values: they accumulate in double, and the
// kernels take the GPUs' paths.
template <class View>
constexpr bool kokkos_blas_takes_sums =
    std::is_same<typename View::non_const_value_type, double>::value && !cpu_code_paths;

// sum_k x_k
template <class XView>
double blas_sum(const XView& x) {
  if constexpr (kokkos_blas_takes_sums<XView>) return KokkosBlas::sum(x);
  else return sum_in_double(x);
}
// sum_k x_k y_k
template <class XView, class YView>
double blas_dot(const XView& x, const YView& y) {
  if constexpr (kokkos_blas_takes_sums<XView> && kokkos_blas_takes_sums<YView>) return KokkosBlas::dot(x, y);
  else return dot_in_double(x, y);
}
#else
template <class XView>
double blas_sum(const XView& x) {
  return sum_in_double(x);
}
template <class XView, class YView>
double blas_dot(const XView& x, const YView& y) {
  return dot_in_double(x, y);
}
#endif

// z_k = x_k y_k
template <class ZView, class XView, class YView>
void blas_elementwise_product(const ZView& z, const XView& x, const YView& y) {
#ifdef MPMFLOW_HAVE_KOKKOS_KERNELS
  KokkosBlas::mult(real_t(0), z, real_t(1), x, y);
#else
  Kokkos::parallel_for(
      "blas_elementwise_product", Kokkos::RangePolicy<ExecutionSpace>(0, z.extent(0)),
      KOKKOS_LAMBDA(const int k) { z(k) = x(k) * y(k); });
#endif
}

}  // namespace mpmflow
