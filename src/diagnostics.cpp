#include "diagnostics.hpp"

#include "kernels/blas1.hpp"

namespace mpmflow {

ConservationTotals DiagnosticsCalculator::compute(const ParticleState& particles) {
  ConservationTotals totals;
  if (particles.count == 0) return totals;
  if (static_cast<index_t>(scratch_.extent(0)) < particles.count)
    Kokkos::realloc(scratch_, particles.count);
  const auto range = std::make_pair(index_t(0), particles.count);
  const auto m = Kokkos::subview(particles.mass, range);
  const auto vx = Kokkos::subview(particles.velocity_x, range);
  const auto vy = Kokkos::subview(particles.velocity_y, range);
  const auto e = Kokkos::subview(particles.specific_energy, range);
  const auto mv = Kokkos::subview(scratch_, range);

  totals.mass = blas_sum(m);
  totals.internal_energy = blas_dot(m, e);          // sum M e
  blas_elementwise_product(mv, m, vx);              // M Vx
  totals.momentum_x = blas_sum(mv);
  totals.kinetic_energy = 0.5 * blas_dot(mv, vx);   // sum M Vx^2 / 2
  blas_elementwise_product(mv, m, vy);              // M Vy
  totals.momentum_y = blas_sum(mv);
  totals.kinetic_energy += 0.5 * blas_dot(mv, vy);
  return totals;
}

}  // namespace mpmflow
