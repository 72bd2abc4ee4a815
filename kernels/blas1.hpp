#pragma once
// BLAS-1 on particle Views: Kokkos Kernels' KokkosBlas when the build has it (the default), else
// the same operations as plain Kokkos reductions, so a minimal GPU build needs Kokkos alone.
#include "kernels/types.hpp"

#ifdef MPMFLOW_HAVE_KOKKOS_KERNELS
#include <KokkosBlas1_dot.hpp>
#include <KokkosBlas1_mult.hpp>
#include <KokkosBlas1_sum.hpp>
#endif

namespace mpmflow {

// sum_k x_k
template <class XView>
real_t blas_sum(const XView& x) {
#ifdef MPMFLOW_HAVE_KOKKOS_KERNELS
  return KokkosBlas::sum(x);
#else
  real_t result = 0;
  Kokkos::parallel_reduce(
      "blas_sum", Kokkos::RangePolicy<ExecutionSpace>(0, x.extent(0)),
      KOKKOS_LAMBDA(const int k, real_t& acc) { acc += x(k); }, result);
  return result;
#endif
}

// sum_k x_k y_k
template <class XView, class YView>
real_t blas_dot(const XView& x, const YView& y) {
#ifdef MPMFLOW_HAVE_KOKKOS_KERNELS
  return KokkosBlas::dot(x, y);
#else
  real_t result = 0;
  Kokkos::parallel_reduce(
      "blas_dot", Kokkos::RangePolicy<ExecutionSpace>(0, x.extent(0)),
      KOKKOS_LAMBDA(const int k, real_t& acc) { acc += x(k) * y(k); }, result);
  return result;
#endif
}

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
