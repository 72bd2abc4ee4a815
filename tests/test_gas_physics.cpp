// The pointwise physics of gas_physics.hpp that the sub-cell consistency of the step rests on (the
// pressure relaxation's fraction and volume shares, the volume correction's density), and the
// nodes' volume fraction (grid_phases.hpp) the correction reads.
#include <gtest/gtest.h>

#include <cmath>

#include "gas_physics.hpp"
#include "grid_phases.hpp"

namespace mpmflow {
namespace {

TEST(SubCellConsistency, TheAcousticFractionIsTheShareOfACellSoundCrossesAtMostAll) {
  const double h = 0.1;
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.01 / h, 2.0), 0.2);
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.1 / h, 2.0), 1.0);
  EXPECT_DOUBLE_EQ(acoustic_fraction(0.01 / h, 0.0), 0.0);
}

TEST(SubCellConsistency, RelativeSpreadIsTheVolumeWeightedDeviationOverTheMean) {
  // Two particles of volume 1 with q = 0.9 and 1.1: mean 1, deviation 0.1.
  EXPECT_NEAR(relative_spread(2.0, 0.9 + 1.1, 0.81 + 1.21), 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(relative_spread(2.0, 2.0, 2.0), 0.0);  // all equal
}

TEST(SubCellConsistency, PressureRelaxationActsOnNoiseAtTheAcousticRateAndLeavesShocksAlone) {
  const double gamma = 1.4, h = 0.1, dt = 0.01;
  // A cell of gas with c = 1: e = 1 / (gamma (gamma - 1)).
  const double mass = 1.4, energy = mass / (gamma * (gamma - 1));
  // Quiet: the acoustic fraction dt c / h = 0.1.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.0, 0.0), 0.1, 1e-12);
  // Noise of 5 %: 1 - 0.05 / 0.25 of it.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.05, 0.01), 0.08, 1e-12);
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.01, 0.05), 0.08, 1e-12);
  // A shock or a contact within the cell (spread 25 % or more): nothing.
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.3, 0.0), 0.0);
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, energy, 0.0, 0.25), 0.0);
  // A long step: at most all the way.
  EXPECT_NEAR(pressure_relaxation_fraction(gamma, 1.0 / h, 1.0, mass, energy, 0.0, 0.0), 1.0, 1e-12);
  // An empty cell, or one without internal energy: nothing.
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 0.0, 0.0, 0.0, 0.0, 0.0), 0.0);
  EXPECT_EQ(pressure_relaxation_fraction(gamma, dt / h, 1.0, mass, 0.0, 0.0, 0.0), 0.0);
}

TEST(SubCellConsistency, RelaxedVolumeSharesKeepTheCellsVolumeAndFollowTheIsentrope) {
  const double gamma = 1.4;
  // Three particles of a cell with pressures around 1: at the common pressure their volumes sum to
  // the cell's (to round-off), the high-pressure particle expands and the low one is compressed.
  const double volume[3] = {0.2, 0.3, 0.5}, pressure[3] = {1.1, 0.95, 0.99};
  double total = 0, pressure_volume = 0;
  for (int k = 0; k < 3; ++k) total += volume[k], pressure_volume += volume[k] * pressure[k];
  const double mean = pressure_volume / total;
  // A particle's volume at the common pressure: its volume times relaxed_volume_ratio.
  auto relaxed_volume_share = [&](double v, double p, double common) {
    return v * relaxed_volume_ratio(p, common, 1 / (gamma * common));
  };
  double shares = 0;
  for (int k = 0; k < 3; ++k) shares += relaxed_volume_share(volume[k], pressure[k], mean);
  EXPECT_NEAR(shares, total, 1e-15);
  EXPECT_GT(relaxed_volume_share(volume[0], pressure[0], mean), volume[0]);
  EXPECT_LT(relaxed_volume_share(volume[1], pressure[1], mean), volume[1]);
  // To first order the isentrope V (p / P)^(1 / gamma): 2 % off in pressure, 4e-5 relative off in volume.
  const double exact = volume[0] * std::pow(1.02, 1 / gamma);
  EXPECT_NEAR(relaxed_volume_share(volume[0], 1.02, 1.0), exact, 1e-4 * exact);
}

TEST(SubCellConsistency, VolumeCorrectionCompressesOverfilledAndExpandsUnderfilledSpace) {
  const double rho = 1.4, rate = 0.1;
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 1.0, rate), rho);
  EXPECT_NEAR(volume_corrected_density(rho, 1.1, rate), rho * 1.01, 1e-12);  // over-filled: denser
  EXPECT_NEAR(volume_corrected_density(rho, 0.9, rate), rho * 0.99, 1e-12);  // part empty: lighter
  // Where the gas does not fill the stencil (a free surface, a near-vacuum) or phi is wild: unchanged.
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 0.4, rate), rho);
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, 2.5, rate), rho);
  EXPECT_DOUBLE_EQ(volume_corrected_density(rho, std::nan(""), rate), rho);
}

TEST(SubCellConsistency, NodeVolumeFractionIsNeutralWhereTheSpaceIsUnknownAndOneSidedNextToABody) {
  const double smallest = 0.25;
  EXPECT_DOUBLE_EQ(node_volume_fraction(1.1, 1.0, smallest), 1.1);
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.5, 0.5, smallest), 1.0);  // on a side: half the space, half the volume
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.3, 0.0, smallest), 1.0);  // beyond the domain, at a far-field side
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.3, 0.2, smallest), 1.0);  // a corner cut by a body
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.45, -0.5, smallest), 0.9);  // next to a body: a shortfall counts
  EXPECT_DOUBLE_EQ(node_volume_fraction(0.6, -0.5, smallest), 1.0);   // an excess does not
}

}  // namespace
}  // namespace mpmflow
