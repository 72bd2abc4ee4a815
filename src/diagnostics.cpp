#include "diagnostics.hpp"

#include "kernels/blas1.hpp"

#include <cmath>

namespace mpmflow {

ConservationTotals particle_totals(const ParticleState& particles) {
  ConservationTotals totals;
  if (particles.count == 0) return totals;
  const auto range = std::make_pair(index_t(0), particles.count);
  const auto m = Kokkos::subview(particles.mass, range);
  const auto vx = Kokkos::subview(particles.velocity_x, range);
  const auto vy = Kokkos::subview(particles.velocity_y, range);
  const auto e = Kokkos::subview(particles.specific_energy, range);
  const RealView mv(Kokkos::view_alloc(Kokkos::WithoutInitializing, std::string("diagnostics_momentum")),
                    particles.count);  // M Vx, then M Vy

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

DiagnosticColumns obstacle_force_columns(const CaseConfig& config, const std::vector<double>& mean_forces) {
  DiagnosticColumns columns;
  const GasState& inf = config.boundaries.free_stream;
  const double speed = std::hypot(double(inf.velocity_x), double(inf.velocity_y));
  const bool coefficients = config.boundaries.has_free_stream && speed > 0;
  for (size_t k = 0; k < config.obstacles.size(); ++k) {
    const std::string name = "obstacle" + std::to_string(k) + "_";
    const double fx = k * 2 + 1 < mean_forces.size() ? mean_forces[2 * k] : 0.0;
    const double fy = k * 2 + 1 < mean_forces.size() ? mean_forces[2 * k + 1] : 0.0;
    columns.emplace_back(name + "force_x", fx);
    columns.emplace_back(name + "force_y", fy);
    if (!coefficients) continue;
    const double ux = inf.velocity_x / speed, uy = inf.velocity_y / speed;
    const double length = config.obstacles[k].reference_length;
    const double q_times_length = 0.5 * inf.density * speed * speed * length;
    columns.emplace_back(name + "drag_coefficient", (fx * ux + fy * uy) / q_times_length);
    columns.emplace_back(name + "lift_coefficient", (-fx * uy + fy * ux) / q_times_length);
  }
  return columns;
}

}  // namespace mpmflow
