// Merging of tiny particles (src/particle_merging.hpp): which particles merge, with whom, and that
// mass, momentum, total energy and volume are conserved.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <vector>

#include "allocation_tracker.hpp"
#include "gas_physics.hpp"
#include "geometry.hpp"
#include "particle_merging.hpp"
#include "round_off.hpp"

namespace mpmflow {
namespace {

struct HostParticle {
  long long id;
  real_t x, y, vx, vy, mass, density, specific_energy;
};

// A 4 x 4 grid of unit cells, 2 x 2 particles per cell: a placed particle has volume 1/4, and a
// split particle (negative id) under 1/16 may merge.
GridGeometry unit_grid() {
  GridGeometry g;
  g.origin_x = 0;
  g.origin_y = 0;
  g.spacing_x = 1;
  g.spacing_y = 1;
  g.nodes_x = 5;
  g.nodes_y = 5;
  return g;
}

CaseConfig merging_case() {
  CaseConfig c;
  c.physics.gamma = 1.4;
  c.particles.per_cell_x = 2;
  c.particles.per_cell_y = 2;
  c.numerics.merge_particles = true;
  c.numerics.split_particles = true;
  return c;
}

// view(k) = value(host[k]) for every particle.
template <class ViewType, class Value>
void fill(const ViewType& view, const std::vector<HostParticle>& host, const Value& value) {
  auto h = Kokkos::create_mirror_view(view);
  for (size_t k = 0; k < host.size(); ++k) h(k) = value(host[k]);
  Kokkos::deep_copy(view, h);
}

// The particles, each with the domain of a placed particle halved along both axes (stretch 1/2) and
// no artificial viscosity.
ParticleState to_particles(const GridGeometry& g, const std::vector<HostParticle>& host) {
  ParticleState pt(static_cast<index_t>(host.size()));
  pt.count = static_cast<index_t>(host.size());
  fill(pt.id, host, [](const HostParticle& p) { return p.id; });
  fill(pt.position_x, host, [](const HostParticle& p) { return p.x; });
  fill(pt.position_y, host, [](const HostParticle& p) { return p.y; });
  fill(pt.velocity_x, host, [](const HostParticle& p) { return p.vx; });
  fill(pt.velocity_y, host, [](const HostParticle& p) { return p.vy; });
  fill(pt.mass, host, [](const HostParticle& p) { return p.mass; });
  fill(pt.density, host, [](const HostParticle& p) { return p.density; });
  fill(pt.specific_energy, host, [](const HostParticle& p) { return p.specific_energy; });
  fill(pt.domain_stretch_x, host, [](const HostParticle&) { return 0.5; });
  fill(pt.domain_stretch_y, host, [](const HostParticle&) { return 0.5; });
  fill(pt.cell, host, [&](const HostParticle& p) { return g.cell_of(p.x, p.y); });
  return pt;
}

struct Totals {
  double mass = 0, momentum_x = 0, momentum_y = 0, energy = 0, volume = 0;
};

// Per id: (mass, density, x, y, vx, vy, specific energy); and the totals.
std::map<long long, std::vector<double>> by_id(const ParticleState& pt, Totals& totals) {
  auto h = [](const auto& v) { return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), v); };
  const auto id = h(pt.id);
  const auto m = h(pt.mass), rho = h(pt.density), x = h(pt.position_x), y = h(pt.position_y);
  const auto vx = h(pt.velocity_x), vy = h(pt.velocity_y), e = h(pt.specific_energy);
  std::map<long long, std::vector<double>> state;
  totals = Totals();
  for (index_t k = 0; k < pt.count; ++k) {
    state[id(k)] = {m(k), rho(k), x(k), y(k), vx(k), vy(k), e(k)};
    totals.mass += m(k);
    totals.momentum_x += m(k) * vx(k);
    totals.momentum_y += m(k) * vy(k);
    totals.energy += m(k) * (e(k) + 0.5 * (vx(k) * vx(k) + vy(k) * vy(k)));
    totals.volume += m(k) / rho(k);
  }
  return state;
}

// Cell (1, 1): three tiny split particles (ids -7, -3, -12), a placed-size one (-20) and a tiny one
// never split (30); cell (2, 1): two tiny split ones (-5, -4); cell (0, 0): one alone (-9). Volumes
// m / rho: tiny ones 1/40 down to 1/100; placed size 1/4.
std::vector<HostParticle> example() {
  return {{-7, 1.2, 1.3, 1.0, -0.5, 0.02, 1.0, 2.0},  {-20, 1.5, 1.5, 0.3, 0.1, 0.25, 1.0, 2.5},
          {-3, 1.7, 1.1, -2.0, 0.5, 0.01, 0.5, 3.0},  {-5, 2.4, 1.6, 0.5, 0.5, 0.015, 1.5, 1.0},
          {-12, 1.9, 1.8, 0.0, 1.0, 0.025, 1.0, 2.0}, {-9, 0.5, 0.5, 1.0, 1.0, 0.01, 1.0, 1.0},
          {-4, 2.2, 1.2, 0.0, 0.0, 0.01, 1.0, 1.5},   {30, 1.4, 1.6, 0.0, 0.0, 0.01, 1.0, 1.5}};
}

TEST(ParticleMerging, TheNearestTinyParticlesOfACellMergeConservingMassMomentumEnergyAndVolume) {
  const GridGeometry g = unit_grid();
  const std::vector<HostParticle> host = example();
  ParticleState pt = to_particles(g, host);
  Totals before, after;
  const auto initial = by_id(pt, before);
  const ParticleMerging merging(merging_case(), g);
  EXPECT_EQ(merging.merge(pt), 2);
  EXPECT_EQ(pt.count, 6);
  const auto merged = by_id(pt, after);
  // Cell (1, 1): of -12, -7 and -3, -7 and -3 merge into -7 (the least merge_cost: 0.0019 against
  // 0.0038 for -12 and -3, 0.0082 for -12 and -7); -12 (left over), -20 (not tiny) and 30 (never
  // split) stay. Cell (2, 1): -5 and -4 into -5. -9 has no partner.
  for (long long id : {-7, -5, -9, -12, -20, 30}) EXPECT_EQ(merged.count(id), 1u) << id;
  const auto& a = initial.at(-7);
  const auto& b = initial.at(-3);
  const auto& c = merged.at(-7);
  EXPECT_DOUBLE_EQ(c[0], a[0] + b[0]);
  EXPECT_NEAR(c[1], (a[0] + b[0]) / (a[0] / a[1] + b[0] / b[1]), round_off(1e-14));
  EXPECT_NEAR(c[2], (a[0] * a[2] + b[0] * b[2]) / (a[0] + b[0]), round_off(1e-14));  // centre of mass
  EXPECT_NEAR(c[3], (a[0] * a[3] + b[0] * b[3]) / (a[0] + b[0]), round_off(1e-14));
  // The kinetic energy of the relative motion became heat.
  EXPECT_GT(c[6], (a[0] * a[6] + b[0] * b[6]) / (a[0] + b[0]) + 1e-3);
  for (long long id : {-9, -12, -20, 30}) EXPECT_EQ(merged.at(id), initial.at(id)) << id;
  EXPECT_NEAR(after.mass, before.mass, round_off(1e-15) * before.mass);
  EXPECT_NEAR(after.momentum_x, before.momentum_x, round_off(1e-15));
  EXPECT_NEAR(after.momentum_y, before.momentum_y, round_off(1e-15));
  EXPECT_NEAR(after.energy, before.energy, round_off(1e-15) * before.energy);
  EXPECT_NEAR(after.volume, before.volume, round_off(1e-15) * before.volume);
}

// Merging runs every step: its lists and their host copies are kept from call to call, so that a
// second merge of as many candidates allocates nothing (on a GPU an allocation and its free cost
// more than the merge's kernels).
TEST(ParticleMerging, ASecondMergeOfAsManyCandidatesAllocatesNothing) {
  const GridGeometry g = unit_grid();
  const ParticleMerging merging(merging_case(), g);
  for (int round = 0; round < 2; ++round) {
    ParticleState pt = to_particles(g, example());  // the same particles each round
    const AllocationTracker allocations;
    EXPECT_EQ(merging.merge(pt), 2) << "round " << round;
    if (round == 1) EXPECT_EQ(allocations.allocation_count(), 0) << "allocations in the second merge";
  }
}

TEST(ParticleMerging, TheResultDoesNotDependOnTheParticleOrder) {
  const GridGeometry g = unit_grid();
  std::vector<HostParticle> host = example();
  ParticleState first = to_particles(g, host);
  std::reverse(host.begin(), host.end());
  ParticleState second = to_particles(g, host);
  const ParticleMerging merging(merging_case(), g);
  merging.merge(first);
  merging.merge(second);
  Totals ignored;
  EXPECT_EQ(by_id(first, ignored), by_id(second, ignored));
}

TEST(ParticleMerging, OffUnlessTheCaseAsksAndUnsplitOrModeratelyCompressedParticlesNeverMerge) {
  const GridGeometry g = unit_grid();
  CaseConfig off = merging_case();
  off.numerics.merge_particles = false;
  ParticleState pt = to_particles(g, example());
  EXPECT_EQ(ParticleMerging(off, g).merge(pt), 0);
  CaseConfig unsplit = merging_case();
  unsplit.numerics.split_particles = false;
  EXPECT_EQ(ParticleMerging(unsplit, g).merge(pt), 0);
  EXPECT_EQ(pt.count, 8);
  // Particles never split do not merge, however compressed; split ones at a third of the placed
  // volume do not either.
  ParticleState compressed =
      to_particles(g, {{1, 0.3, 0.3, 0, 0, 0.1, 10.0, 1.0}, {2, 0.6, 0.6, 0, 0, 0.1, 10.0, 1.0},
                       {-1, 1.3, 0.3, 0, 0, 0.25, 3.0, 1.0}, {-2, 1.6, 0.6, 0, 0, 0.25, 3.0, 1.0}});
  EXPECT_EQ(ParticleMerging(merging_case(), g).merge(compressed), 0);
}

// The pairing alone (pair_candidates): per cell the cheapest pair first, costs that weigh distance by
// the pair's reduced mass, the particle with the smaller id kept, in any input order.
TEST(ParticleMerging, PairsTheCheapestFirstAndKeepsTheSmallerId) {
  // One cell: a and b 0.1 apart, c 0.3 from b, d 0.35 from c: (a, b) then (c, d). A heavy e in
  // another cell, 0.1 from f and 0.12 from a light g: m_e m_g / (m_e + m_g) 0.12^2 is the cheaper.
  const std::vector<MergeCandidate> candidates = {
      {5, -1, 10, 0.1, 0.1, 1.0},  {5, -2, 11, 0.2, 0.1, 1.0},  {5, -3, 12, 0.5, 0.1, 1.0},
      {5, -4, 13, 0.5, 0.45, 1.0}, {6, -9, 20, 1.5, 0.5, 10.0}, {6, -7, 21, 1.6, 0.5, 10.0},
      {6, -8, 22, 1.5, 0.62, 0.1}};
  for (int order = 0; order < 2; ++order) {
    std::vector<MergeCandidate> listed = candidates;
    if (order == 1) std::reverse(listed.begin(), listed.end());
    std::vector<index_t> keep, gone;
    pair_candidates(listed, keep, gone);
    std::vector<std::pair<index_t, index_t>> pairs;
    for (size_t k = 0; k < keep.size(); ++k) pairs.emplace_back(keep[k], gone[k]);
    std::sort(pairs.begin(), pairs.end());
    const std::vector<std::pair<index_t, index_t>> expected = {{11, 10}, {13, 12}, {20, 22}};
    EXPECT_EQ(pairs, expected) << "order " << order;
  }
}

// A flow symmetric about a line pairs mirror images: a particle on the line whose two nearest are
// mirror images of each other merges with neither (either would break the symmetry); the mirror
// pair merges, onto the line.
TEST(ParticleMerging, APairingOfMirrorImagesIsItsOwnMirrorImage) {
  // The diagonal x = y of a cell: c on it, a and b mirror images 0.1 from c, d on it 0.3 from c.
  // Round-off left the mirror images a part in 1e13 off (as mirror-image particles of a run are), in
  // single precision 8 epsilons (9.5e-7, some 16 units of their coordinates' last place: with a
  // tie tolerance of 1e-9 there, below float's epsilon, c paired with a).
  const real_t off = real_t(std::max(1e-13, 8.0 * real_epsilon)), d = real_t(0.1 / std::sqrt(2.0));
  const std::vector<MergeCandidate> candidates = {{0, -5, 0, 0.5, 0.5, 1.0},
                                                  {0, -6, 1, 0.5 + d + off, 0.5 - d, 1.0},
                                                  {0, -3, 2, 0.5 - d, 0.5 + d, 1.0},
                                                  {0, -4, 3, 0.8, 0.8, 1.0}};
  std::vector<index_t> keep, gone;
  pair_candidates(candidates, keep, gone);
  // (c, a) and (c, b) cost the same to round-off: neither is taken; a and b pair at the next level,
  // c and d at the one after.
  std::vector<std::pair<index_t, index_t>> pairs;
  for (size_t k = 0; k < keep.size(); ++k) pairs.emplace_back(keep[k], gone[k]);
  std::sort(pairs.begin(), pairs.end());
  const std::vector<std::pair<index_t, index_t>> expected = {{0, 3}, {1, 2}};
  EXPECT_EQ(pairs, expected);
}

// Two tiny split particles of a cell either side of a circle's surface: their centre of mass is
// inside it, so the merged particle takes the kept one's place (the smaller id, -8), outside.
TEST(ParticleMerging, AMergedParticleIsNeverPutInsideAnObstacle) {
  CaseConfig config = merging_case();
  config.domain = {0, 4, 0, 4, 4, 4};
  ObstacleConfig circle;
  circle.centre_x = circle.centre_y = 2;
  circle.radius = 0.8;
  config.obstacles = {circle};
  const GridSlab slab = make_grid_slab(config.domain, 0, 4);
  const ParticleBoundaries boundaries(config, slab, make_obstacle_grid(config.obstacles, slab, config.boundaries));
  const std::vector<HostParticle> pair = {{-8, 1.15, 1.9, 0, 0, 0.01, 1.0, 1.0}, {-6, 1.9, 1.15, 0, 0, 0.01, 1.0, 1.0}};
  for (const HostParticle& p : pair) ASSERT_GT(std::hypot(p.x - 2, p.y - 2), 0.8);
  ASSERT_LT(std::hypot(1.525 - 2, 1.525 - 2), 0.8);  // the centre of mass is inside
  ParticleState pt = to_particles(slab.geometry, pair);
  ASSERT_EQ(ParticleMerging(config, slab.geometry).merge(pt, boundaries), 1);
  Totals totals;
  const auto merged = by_id(pt, totals);
  ASSERT_EQ(merged.count(-8), 1u);
  EXPECT_DOUBLE_EQ(merged.at(-8)[2], real_t(1.15));
  EXPECT_DOUBLE_EQ(merged.at(-8)[3], real_t(1.9));
  EXPECT_NEAR(totals.mass, 0.02, round_off(1e-16));
  // Without the obstacle the pair merges at its centre of mass.
  ParticleState free = to_particles(slab.geometry, pair);
  ParticleMerging(config, slab.geometry).merge(free);
  const auto centre = by_id(free, totals);
  EXPECT_DOUBLE_EQ(centre.at(-8)[2], real_t(1.525));
}

// The pairing's definition, written plainly (pair_candidates orders the pairs a slice at a time and
// drops those of taken particles): every pair of a cell sorted by cost, then by ids; level by level,
// a level starting at the cheapest pair of two free particles and holding every pair within
// merge_tie_tolerance of it, whose pairs of free particles claiming no particle another pair of the
// level claims are taken. The pairs as (kept, merged away) indices, sorted.
std::vector<std::pair<index_t, index_t>> pairs_by_definition(std::vector<MergeCandidate> candidates) {
  std::sort(candidates.begin(), candidates.end(), [](const MergeCandidate& a, const MergeCandidate& b) {
    return a.cell != b.cell ? a.cell < b.cell : a.id < b.id;
  });
  std::vector<std::pair<index_t, index_t>> result;
  for (size_t begin = 0, end = 0; begin < candidates.size(); begin = end) {
    end = begin;
    while (end < candidates.size() && candidates[end].cell == candidates[begin].cell) ++end;
    struct Pair {
      real_t cost;
      size_t a, b;
    };
    std::vector<Pair> pairs;
    for (size_t a = begin; a < end; ++a)
      for (size_t b = a + 1; b < end; ++b) pairs.push_back({merge_cost(candidates[a], candidates[b]), a, b});
    std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
      return x.cost != y.cost ? x.cost < y.cost : (x.a != y.a ? x.a < y.a : x.b < y.b);
    });
    std::vector<bool> taken(candidates.size(), false);
    const auto is_free = [&](const Pair& p) { return !taken[p.a] && !taken[p.b]; };
    for (size_t k = 0; k < pairs.size();) {
      if (!is_free(pairs[k])) {
        ++k;
        continue;
      }
      size_t level_end = k;
      while (level_end < pairs.size() && pairs[level_end].cost <= pairs[k].cost * (1 + merge_tie_tolerance))
        ++level_end;
      std::map<size_t, int> claims;
      for (size_t j = k; j < level_end; ++j)
        if (is_free(pairs[j])) ++claims[pairs[j].a], ++claims[pairs[j].b];
      for (size_t j = k; j < level_end; ++j)
        if (claims[pairs[j].a] == 1 && claims[pairs[j].b] == 1) {
          taken[pairs[j].a] = taken[pairs[j].b] = true;
          result.emplace_back(candidates[pairs[j].a].index, candidates[pairs[j].b].index);
        }
      k = level_end;
    }
  }
  std::sort(result.begin(), result.end());
  return result;
}

// Crowded cells, as the linear Mach 3 cylinder's early steps have (up to 279 candidates in a cell):
// pair_candidates gives the pairs of the definition. Random places and masses; and places on a
// lattice with two masses, whose many costs are exactly equal (levels of several pairs, contested
// particles, levels that run past a slice of ordered pairs).
TEST(ParticleMerging, CrowdedCellsPairAsTheDefinitionSays) {
  std::mt19937 random(20261207);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<MergeCandidate> candidates;
  long long next_id = -1;
  index_t next_index = 0;
  const auto add = [&](long long cell, real_t x, real_t y, real_t mass) {
    candidates.push_back({cell, next_id--, next_index++, x, y, mass});
  };
  for (const int count : {300, 120, 37, 9, 3, 2, 1})  // random places and masses, a cell each
    for (int k = 0; k < count; ++k) add(count, unit(random), unit(random), 0.5 + unit(random));
  for (int i = 0; i < 14; ++i)  // a 14 x 14 lattice, one cell
    for (int j = 0; j < 14; ++j) add(1000, i / 16.0, j / 16.0, (i + j) % 3 == 0 ? 2.0 : 1.0);
  for (int i = 0; i < 5; ++i)  // a 5 x 5 lattice of equal masses, one cell
    for (int j = 0; j < 5; ++j) add(1001, i * 0.25, j * 0.25, 1.0);
  // The candidates in an order of their own: the result does not depend on it.
  std::shuffle(candidates.begin(), candidates.end(), random);

  std::vector<index_t> keep, gone;
  pair_candidates(candidates, keep, gone);
  ASSERT_EQ(keep.size(), gone.size());
  std::vector<std::pair<index_t, index_t>> pairs;
  for (size_t k = 0; k < keep.size(); ++k) pairs.emplace_back(keep[k], gone[k]);
  std::sort(pairs.begin(), pairs.end());
  const auto expected = pairs_by_definition(candidates);
  EXPECT_EQ(pairs, expected);
  // Most candidates paired: (300 + 120 + 37 + 9 + 3 + 2 + 196 + 25) / 2 = 346 at most.
  EXPECT_GT(expected.size(), 300u);
}

}  // namespace
}  // namespace mpmflow
