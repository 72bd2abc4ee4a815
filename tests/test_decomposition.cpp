// The slab decomposition and the pieces of a distributed run that a single process can check:
// even and balanced slabs, owners of cells, slabs along y, and a one-rank solver that owns a slab
// cut along y giving the same answer as the whole grid along x.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numeric>

#include "case_config.hpp"
#include "grid.hpp"
#include "parallel.hpp"
#include "particle_migration.hpp"
#include "round_off.hpp"

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

// The message of the error that even slabs of a cells_x x cells_y grid on `ranks` ranks along
// `axis` give; empty if they give none.
std::string even_slabs_error(int cells_x, int cells_y, int axis, int ranks) {
  try {
    SlabDecomposition::even(config_with_cells(cells_x, cells_y, axis), ranks);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(Decomposition, TooManyRanksIsAnErrorNamingTheKeyAndTheLimit) {
  const std::string message = even_slabs_error(10, 40, /*axis=*/0, 4);
  EXPECT_NE(message.find("case.json: /domain/cells_x"), std::string::npos) << message;
  EXPECT_NE(message.find("at most 3 ranks"), std::string::npos) << message;
  // Along y, the rows count.
  EXPECT_THROW(SlabDecomposition::even(config_with_cells(100, 8, /*axis=*/1), 3), ConfigError);
  EXPECT_NO_THROW(SlabDecomposition::even(config_with_cells(100, 9, /*axis=*/1), 3));
}

TEST(Decomposition, OneRankTakesAnyWidthAlongTheAxisButTwoNeedTheStencilEach) {
  // A shock tube along y, one cell across, with the default axis x: one rank holds it whole.
  const SlabDecomposition one = SlabDecomposition::even(config_with_cells(1, 100, /*axis=*/0), 1);
  EXPECT_EQ(one.begin(0), 0);
  EXPECT_EQ(one.end(0), 1);
  const std::string message = even_slabs_error(5, 100, /*axis=*/0, 2);
  EXPECT_NE(message.find("at most 1 rank,"), std::string::npos) << message;
  EXPECT_NE(message.find("or /decomposition/axis \"y\" (its 100 cells)"), std::string::npos) << message;
  EXPECT_NO_THROW(SlabDecomposition::even(config_with_cells(6, 100, /*axis=*/0), 2));
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
  EXPECT_NEAR(slab.geometry.node_y(0), 0.3, round_off(1e-15));
  // A particle just below the slab (not yet migrated) is put in the first owned row of cells,
  // so its stencil stays on local nodes; with include_ghosts, in the ghost row.
  const GridGeometry& g = slab.geometry;
  EXPECT_EQ(g.cell_j_of(g.cell_of(1.05, 0.39)), 1);
  EXPECT_EQ(g.cell_j_of(g.cell_of(1.05, 0.39, /*include_ghosts=*/true)), 0);
  // A node's and a cell's column and row from their indices, the inverses of node_index and of
  // cell_of's numbering (ci + cells_x cj).
  EXPECT_EQ(g.node_i_of(g.node_index(22, 5)), 22);
  EXPECT_EQ(g.node_j_of(g.node_index(22, 5)), 5);
  EXPECT_EQ(g.node_i_of(g.node_index(0, 3)), 0);
  EXPECT_EQ(g.node_j_of(g.node_index(0, 3)), 3);
  const index_t cell = g.cell_of(1.05, 0.55);  // global cell (10, 5): local column 11, row 2
  EXPECT_EQ(g.cell_i_of(cell), 11);
  EXPECT_EQ(g.cell_j_of(cell), 2);
  EXPECT_EQ(cell, g.cell_i_of(cell) + g.cells_x() * g.cell_j_of(cell));
}

// Index spaces of the slabs of a 3-slab split along `axis` of a 20 x 10 cell grid.
std::vector<GridSlab> three_slabs(int axis) {
  DomainConfig domain;
  domain.x_min = 0, domain.x_max = 2, domain.y_min = 0, domain.y_max = 1;
  domain.cells_x = 20, domain.cells_y = 10;
  CaseConfig config = config_with_cells(20, 10, axis);
  const SlabDecomposition d = SlabDecomposition::even(config, 3);
  std::vector<GridSlab> slabs;
  for (int r = 0; r < 3; ++r) slabs.push_back(make_grid_slab(domain, axis, d.begin(r), d.end(r)));
  return slabs;
}

TEST(SlabIndexSpaces, OwnedNodesAndCellsCoverTheDomainOnceAndGhostedRangesHoldThem) {
  for (int axis : {0, 1}) {
    std::vector<int> node_owners(21 * 11, 0), cell_owners(20 * 10, 0);
    for (const GridSlab& slab : three_slabs(axis)) {
      const IndexRange2D nodes = slab.index_space(Ownership::owned, Entity::node, Indexing::global);
      for (index_t j = nodes.begin_y; j < nodes.end_y; ++j)
        for (index_t i = nodes.begin_x; i < nodes.end_x; ++i) ++node_owners[i + 21 * j];
      const IndexRange2D cells = slab.index_space(Ownership::owned, Entity::cell, Indexing::global);
      for (index_t j = cells.begin_y; j < cells.end_y; ++j)
        for (index_t i = cells.begin_x; i < cells.end_x; ++i) ++cell_owners[i + 20 * j];
      // Local and global indices differ by the node offset; the ghosted range is the local grid,
      // one line wider than the owned one on each side.
      const IndexRange2D local = slab.index_space(Ownership::owned, Entity::cell, Indexing::local);
      EXPECT_EQ(local.begin_x + slab.node_offset_x, cells.begin_x);
      EXPECT_EQ(local.begin_y + slab.node_offset_y, cells.begin_y);
      const IndexRange2D ghosted = slab.index_space(Ownership::ghosted, Entity::node, Indexing::local);
      EXPECT_EQ(ghosted, (IndexRange2D{0, slab.geometry.nodes_x, 0, slab.geometry.nodes_y}));
      const IndexRange2D ghosted_cells = slab.index_space(Ownership::ghosted, Entity::cell, Indexing::global);
      EXPECT_EQ(ghosted_cells.begin_x, cells.begin_x - 1);
      EXPECT_EQ(ghosted_cells.end_y, cells.end_y + 1);
    }
    for (int owners : node_owners) EXPECT_EQ(owners, 1) << "axis " << axis;
    for (int owners : cell_owners) EXPECT_EQ(owners, 1) << "axis " << axis;
  }
}

TEST(SlabIndexSpaces, NeighboursShareTheThreeNodeLinesAroundTheirFace) {
  for (int axis : {0, 1}) {
    const std::vector<GridSlab> slabs = three_slabs(axis);
    EXPECT_TRUE(slabs[0].shared_node_space(-1).empty());
    EXPECT_TRUE(slabs[2].shared_node_space(+1).empty());
    for (int r = 0; r + 1 < 3; ++r) {
      const GridSlab &lower = slabs[r], &upper = slabs[r + 1];
      const IndexRange2D a = lower.shared_node_space(+1), b = upper.shared_node_space(-1);
      ASSERT_EQ(a.size(), b.size());
      EXPECT_EQ(a.end(axis) - a.begin(axis), GridSlab::shared_lines);
      // The same global lines, around the face at the upper slab's first owned cell.
      EXPECT_EQ(a.begin(axis) + lower.node_offset(axis), b.begin(axis) + upper.node_offset(axis));
      const index_t face = upper.index_space(Ownership::owned, Entity::cell, Indexing::global).begin(axis);
      EXPECT_EQ(b.begin(axis) + upper.node_offset(axis), face - 1);
      EXPECT_EQ(a.extent_x() * a.extent_y(), GridSlab::shared_lines * (axis == 0 ? 13 : 23));
    }
  }
}

TEST(SlabIndexSpaces, BoundaryLinesAndDomainNodes) {
  const std::vector<GridSlab> slabs = three_slabs(0);
  // The left side and the line beyond it are on the first slab only.
  EXPECT_EQ(slabs[0].boundary_node_line(left_side, 0), (IndexRange2D{1, 2, 0, 13}));
  EXPECT_EQ(slabs[0].boundary_node_line(left_side, 1), (IndexRange2D{0, 1, 0, 13}));
  EXPECT_TRUE(slabs[1].boundary_node_line(left_side, 0).empty());
  EXPECT_TRUE(slabs[0].boundary_node_line(right_side, 0).empty());
  const GridSlab& last = slabs[2];
  const index_t right = last.local_node_x(20);
  EXPECT_EQ(last.boundary_node_line(right_side, 0), (IndexRange2D{right, right + 1, 0, 13}));
  // Bottom and top run along every slab.
  EXPECT_EQ(slabs[1].boundary_node_line(top_side, 1), (IndexRange2D{0, slabs[1].geometry.nodes_x, 12, 13}));
  // The domain's nodes held by the middle slab: all of its nodes along x, none of the ghost rows.
  EXPECT_EQ(slabs[1].domain_node_space(), (IndexRange2D{0, slabs[1].geometry.nodes_x, 1, 12}));
  EXPECT_EQ(slabs[0].domain_node_space().begin_x, 1);
}

TEST(SlabIndexSpaces, GlobalCellOfAPointAnywhereInTheDomain) {
  const std::vector<GridSlab> slabs = three_slabs(0);
  // From any slab, the same global cell: 0.1 cell widths past x = 1.3 is cell 13; clamped at the edges.
  for (const GridSlab& slab : slabs) {
    EXPECT_EQ(slab.global_cell_along(0, 1.31, 0.5), 13);
    EXPECT_EQ(slab.global_cell_along(1, 1.31, 0.55), 5);
    EXPECT_EQ(slab.global_cell_along(0, -0.5, 0.5), 0);
    EXPECT_EQ(slab.global_cell_along(0, 2.0, 0.5), 19);
  }
}

// Migration's test of a particle (OutsideTheCells) gives the cell arithmetic's answer for every
// coordinate: at each face of a slab and up to 64 units of the last place either side of it, where
// its two comparisons must leave the answer to the arithmetic, and a cell's width either side, along
// x and y, with spacings that are not binary fractions (so that the faces' coordinates and the
// quotients round). The first two slabs have an upper face where comparisons alone answer wrongly
// (found by a search over domains and slabs that mirrored the arithmetic): the face at y = 0 comes
// out at 1.1e-16, and the point a unit of the last place below that is in cell 13, above the
// slab, by the arithmetic; so is x = 0.0808 at the second's face; the third slab lies far from the
// origin.
TEST(Decomposition, MigrationTellsALeavingParticleAsTheCellArithmeticDoes) {
  struct Slab {
    int axis;
    real_t low, high;
    int cells;
    index_t begin, end;
  };
  int checked = 0, outside = 0;
  const Slab slabs[] = {{1, -1.3, 1.3, 26, 8, 13}, {0, -2.1, 4.2, 26, 4, 9}, {0, 1000.1, 1001.4, 449, 149, 299}};
  for (const Slab& c : slabs) {
    DomainConfig domain;
    (c.axis == 0 ? domain.x_min : domain.y_min) = c.low;
    (c.axis == 0 ? domain.x_max : domain.y_max) = c.high;
    (c.axis == 0 ? domain.cells_x : domain.cells_y) = c.cells;
    (c.axis == 0 ? domain.cells_y : domain.cells_x) = 7;
    const GridSlab slab = make_grid_slab(domain, c.axis, c.begin, c.end);
    const OutsideTheCells test(slab, c.axis, c.begin, c.end);
    const real_t spacing = (c.high - c.low) / c.cells;
    const real_t origin = c.axis == 0 ? slab.geometry.origin_x : slab.geometry.origin_y;
    for (const index_t face : {c.begin, c.end}) {
      // The face's coordinate as the slab computes it, and as the domain's edge and spacing give it.
      for (const real_t at : {origin + spacing * real_t(face - slab.node_offset(c.axis)), c.low + spacing * face}) {
        for (const real_t away : {real_t(0), spacing * real_t(1e-7), spacing, -spacing * real_t(1e-7), -spacing}) {
          real_t up = at + away, down = at + away;
          for (int k = 0; k <= 64; ++k) {
            for (const real_t coordinate : {up, down}) {
              const index_t cell = slab.global_cell_at(c.axis, coordinate);
              const bool expected = cell < c.begin || cell >= c.end;
              EXPECT_EQ(test(coordinate), expected) << "axis " << c.axis << ", coordinate " << coordinate;
              ++checked;
              outside += expected ? 1 : 0;
            }
            up = std::nextafter(up, std::numeric_limits<real_t>::infinity());
            down = std::nextafter(down, -std::numeric_limits<real_t>::infinity());
          }
        }
      }
    }
    // Well inside, and beyond the domain's edges (clamped to its first and last cells: outside
    // these slabs, which hold neither).
    EXPECT_FALSE(test(c.low + spacing * real_t(c.begin + c.end) / 2));
    EXPECT_TRUE(test(c.low - 1));
    EXPECT_TRUE(test(c.high + 1));
  }
  EXPECT_GT(outside, checked / 4);  // both answers met near the faces
  EXPECT_LT(outside, checked * 3 / 4);
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
