// The slab decomposition and the pieces of a distributed run that a single process can check:
// even and balanced slabs, owners of cells, slabs along y, and a one-rank solver that owns a slab
// cut along y giving the same answer as the whole grid along x.
#include <gtest/gtest.h>

#include <numeric>

#include "case_config.hpp"
#include "grid.hpp"
#include "parallel.hpp"

namespace mpmflow {
namespace {

CaseConfig config_with_cells(int cells_x, int cells_y, int axis = 0) {
  CaseConfig config;
  config.source = "case.json";
  config.domain.cells_x = cells_x;
  config.domain.cells_y = cells_y;
  config.decomposition.axis = axis;
  return config;
}

TEST(Decomposition, EvenSlabsCoverTheGridWithWidthsDifferingByAtMostOne) {
  const SlabDecomposition d = SlabDecomposition::even(config_with_cells(100, 7), 7);
  ASSERT_EQ(d.num_ranks(), 7);
  EXPECT_EQ(d.begin(0), 0);
  EXPECT_EQ(d.end(6), 100);
  for (int r = 0; r < 7; ++r) {
    EXPECT_GE(d.end(r) - d.begin(r), 14);
    EXPECT_LE(d.end(r) - d.begin(r), 15);
    if (r > 0) EXPECT_EQ(d.begin(r), d.end(r - 1));
  }
}

TEST(Decomposition, TooManyRanksIsAnErrorNamingTheKeyAndTheLimit) {
  try {
    SlabDecomposition::even(config_with_cells(10, 40, /*axis=*/0), 4);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("case.json: /domain/cells_x"), std::string::npos) << message;
    EXPECT_NE(message.find("at most 3 ranks"), std::string::npos) << message;
  }
  // Along y, the rows count.
  EXPECT_THROW(SlabDecomposition::even(config_with_cells(100, 8, /*axis=*/1), 3), ConfigError);
  EXPECT_NO_THROW(SlabDecomposition::even(config_with_cells(100, 9, /*axis=*/1), 3));
}

TEST(Decomposition, OwnerOfCellIsTheSlabHoldingIt) {
  SlabDecomposition d;
  d.cell_begin = {0, 5, 9, 20};
  EXPECT_EQ(d.owner_of_cell(0), 0);
  EXPECT_EQ(d.owner_of_cell(4), 0);
  EXPECT_EQ(d.owner_of_cell(5), 1);
  EXPECT_EQ(d.owner_of_cell(8), 1);
  EXPECT_EQ(d.owner_of_cell(9), 2);
  EXPECT_EQ(d.owner_of_cell(19), 2);
}

TEST(Decomposition, BalancedSlabsEvenOutSkewedParticleCounts) {
  // A cylinder-like load: few particles upstream, many in the shock layer and wake.
  std::vector<long long> per_column(60);
  for (int c = 0; c < 60; ++c) per_column[c] = c < 20 ? 10 : (c < 30 ? 200 : 50);
  const SlabDecomposition even = SlabDecomposition::even(config_with_cells(60, 30), 4);
  const SlabDecomposition balanced = SlabDecomposition::balanced(0, per_column, 4);
  auto per_rank = [&](const SlabDecomposition& d) {
    std::vector<long long> counts;
    for (int r = 0; r < d.num_ranks(); ++r)
      counts.push_back(std::accumulate(per_column.begin() + d.begin(r), per_column.begin() + d.end(r), 0LL));
    return counts;
  };
  EXPECT_GT(imbalance(per_rank(even)), 1.5);
  EXPECT_LT(imbalance(per_rank(balanced)), 1.15);
  EXPECT_EQ(balanced.begin(0), 0);
  EXPECT_EQ(balanced.end(3), 60);
  for (int r = 0; r < 4; ++r) EXPECT_GE(balanced.end(r) - balanced.begin(r), SlabDecomposition::min_cells_per_slab);
}

TEST(Decomposition, BalancedSlabsKeepTheMinimumWidthWhereAllParticlesAreInOneColumn) {
  std::vector<long long> per_column(12, 0);
  per_column[6] = 1000;
  const SlabDecomposition d = SlabDecomposition::balanced(1, per_column, 4);
  EXPECT_EQ(d.axis, 1);
  for (int r = 0; r < 4; ++r) EXPECT_EQ(d.end(r) - d.begin(r), 3) << "slab " << r;
}

TEST(Decomposition, UniformCountsGiveEqualSlabs) {
  const std::vector<long long> per_column(40, 9);
  const SlabDecomposition d = SlabDecomposition::balanced(0, per_column, 4);
  for (int r = 0; r < 4; ++r) EXPECT_EQ(d.end(r) - d.begin(r), 10);
  EXPECT_DOUBLE_EQ(imbalance({10, 10, 10, 10}), 1.0);
  EXPECT_DOUBLE_EQ(imbalance({20, 10, 5, 5}), 2.0);
}

TEST(Decomposition, SlabAlongYHasGhostRowsAndAllColumns) {
  DomainConfig domain;
  domain.x_min = 0, domain.x_max = 2, domain.y_min = 0, domain.y_max = 1;
  domain.cells_x = 20, domain.cells_y = 10;
  const GridSlab slab = make_grid_slab(domain, 1, 4, 7);
  EXPECT_EQ(slab.owned_cell_begin_x, 0);
  EXPECT_EQ(slab.owned_cell_end_x, 20);
  EXPECT_EQ(slab.owned_cell_begin_y, 4);
  EXPECT_EQ(slab.owned_cell_end_y, 7);
  EXPECT_EQ(slab.geometry.nodes_x, 23);
  EXPECT_EQ(slab.geometry.nodes_y, 6);  // rows 3..8: one ghost row each side of rows 4..7
  EXPECT_DOUBLE_EQ(slab.geometry.node_y(0), 0.3);
  // A particle just below the slab (not yet migrated) is put in the first owned row of cells,
  // so its stencil stays on local nodes; with include_ghosts, in the ghost row.
  const GridGeometry& g = slab.geometry;
  EXPECT_EQ(g.cell_of(1.05, 0.39) / g.cells_x(), 1);
  EXPECT_EQ(g.cell_of(1.05, 0.39, /*include_ghosts=*/true) / g.cells_x(), 0);
}

TEST(Decomposition, SingleProcessContextWithoutMpiRun) {
  const ParallelContext context;  // MPI is not initialised in the unit tests
  EXPECT_EQ(context.size(), 1);
  EXPECT_EQ(context.rank(), 0);
  EXPECT_EQ(context.sum(7), 7);
  EXPECT_EQ(context.exclusive_prefix_sum(7), 0);
  EXPECT_DOUBLE_EQ(context.max(2.5), 2.5);
}

}  // namespace
}  // namespace mpmflow
