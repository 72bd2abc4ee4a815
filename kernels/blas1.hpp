#pragma once
// BLAS-1 on particle Views: Kokkos Kernels' KokkosBlas when the build has it (the default) and,
// for the sums, the Views hold doubles (below); else the same operations as plain Kokkos
// reductions, so a minimal GPU build needs Kokkos alone.
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
// KokkosBlas sums in the Views' own value type, so it serves where that is double; plain Kokkos
// reductions, with a double accumulator, elsewhere and without Kokkos Kernels.

// sum_k x_k and sum_k x_k y_k as plain Kokkos reductions in double.
template <class XView>
double sum_in_double(const XView& x) {
  double result = 0;
  Kokkos::parallel_reduce(
      "blas_sum", Kokkos::RangePolicy<ExecutionSpace>(0, x.extent(0)),
      KOKKOS_LAMBDA(const int k, double& acc) { acc += x(k); }, result);
  return result;
}
template <class XView, class YView>
double dot_in_double(const XView& x, const YView& y) {
  double result = 0;
  Kokkos::parallel_reduce(
      "blas_dot", Kokkos::RangePolicy<ExecutionSpace>(0, x.extent(0)),
      KOKKOS_LAMBDA(const int k, double& acc) { acc += double(x(k)) * double(y(k)); }, result);
  return result;
}

#ifdef MPMFLOW_HAVE_KOKKOS_KERNELS
// Whether KokkosBlas' sums over View's values accumulate in double.
template <class View>
constexpr bool kokkos_blas_sums_in_double = std::is_same<typename View::non_const_value_type, double>::value;

// sum_k x_k
template <class XView>
double blas_sum(const XView& x) {
  if constexpr (kokkos_blas_sums_in_double<XView>) return KokkosBlas::sum(x);
  else return sum_in_double(x);
}
// sum_k x_k y_k
template <class XView, class YView>
double blas_dot(const XView& x, const YView& y) {
  if constexpr (kokkos_blas_sums_in_double<XView> && kokkos_blas_sums_in_double<YView>) return KokkosBlas::dot(x, y);
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
