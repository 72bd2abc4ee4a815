// The exact Riemann solver against published Sod values (Toro, ch. 4; the reference figures in
// ../shared/conventions.md) and against conservation across its own waves.
#include <gtest/gtest.h>

#include <cmath>

#include "exact_riemann.hpp"

namespace mpmflow {
namespace {

TEST(ExactRiemann, SodStarState) {
  const ExactRiemannSolver sod({1.0, 0.0, 1.0}, {0.125, 0.0, 0.1}, 1.4);
  EXPECT_NEAR(sod.star_pressure(), 0.303130, 1e-6);
  EXPECT_NEAR(sod.star_velocity(), 0.927453, 1e-6);
  EXPECT_NEAR(sod.star_density_left(), 0.426319, 1e-6);
  EXPECT_NEAR(sod.star_density_right(), 0.265574, 1e-6);
  EXPECT_NEAR(sod.right_wave_speed(), 1.752156, 1e-6);
}

TEST(ExactRiemann, SodWavePositionsAtReferenceTime) {
  const ExactRiemannSolver sod({1.0, 0.0, 1.0}, {0.125, 0.0, 0.1}, 1.4);
  const double t = 0.143, x0 = 0.5;
  EXPECT_NEAR(x0 + sod.right_wave_speed() * t, 0.75056, 1e-5);
  EXPECT_NEAR(x0 + sod.star_velocity() * t, 0.63263, 1e-5);
  // Just either side of the shock and of the contact the sampled states jump as they should.
  EXPECT_NEAR(sod.solution(0.7505, t, x0).density, 0.265574, 1e-6);
  EXPECT_NEAR(sod.solution(0.7507, t, x0).density, 0.125, 1e-12);
  EXPECT_NEAR(sod.solution(0.6325, t, x0).density, 0.426319, 1e-6);
  EXPECT_NEAR(sod.solution(0.6328, t, x0).density, 0.265574, 1e-6);
  // The rarefaction fan is continuous at its head and tail, and isentropic inside.
  const double head = x0 - std::sqrt(1.4) * t;
  EXPECT_NEAR(sod.solution(head + 1e-9, t, x0).density, 1.0, 1e-6);
  const auto inside = sod.solution(0.45, t, x0);
  EXPECT_NEAR(inside.pressure / std::pow(inside.density, 1.4), 1.0, 1e-12);
}

TEST(ExactRiemann, ShockSatisfiesRankineHugoniot) {
  // A strong two-shock problem: mass and momentum fluxes balance across the right shock.
  const ExactRiemannSolver rp({1.0, 2.0, 1.0}, {1.0, -2.0, 1.0}, 1.4);
  const double s = rp.right_wave_speed();
  const PrimitiveState1D a{rp.star_density_right(), rp.star_velocity(), rp.star_pressure()};
  const PrimitiveState1D b{1.0, -2.0, 1.0};
  EXPECT_NEAR(a.density * (a.velocity - s), b.density * (b.velocity - s), 1e-10);
  EXPECT_NEAR(a.density * (a.velocity - s) * a.velocity + a.pressure,
              b.density * (b.velocity - s) * b.velocity + b.pressure, 1e-10);
}

TEST(ExactRiemann, VacuumIsRefused) {
  EXPECT_THROW(ExactRiemannSolver({1.0, -10.0, 1.0}, {1.0, 10.0, 1.0}, 1.4), std::invalid_argument);
}

}  // namespace
}  // namespace mpmflow
