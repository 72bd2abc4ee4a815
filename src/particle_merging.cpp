#include "particle_merging.hpp"

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "gas_physics.hpp"
#include "kernels/particle_compaction.hpp"

namespace mpmflow {
namespace {

// Particle `gone` merged into particle `keep`. `gone` is left with no mass, which marks it for
// removal.
KOKKOS_INLINE_FUNCTION void merge_pair(const ParticleState& pt, index_t keep, index_t gone,
                                       const ParticleBoundaries& boundaries) {
  const real_t m1 = pt.mass(keep), m2 = pt.mass(gone);
  const real_t m = m1 + m2;
  const real_t w1 = m1 / m, w2 = m2 / m;
  const real_t volume = m1 / pt.density(keep) + m2 / pt.density(gone);
  const real_t du = pt.velocity_x(keep) - pt.velocity_x(gone);
  const real_t dv = pt.velocity_y(keep) - pt.velocity_y(gone);
  // Kinetic energy of the relative motion, lost by averaging the momenta: becomes heat.
  const real_t relative_kinetic_energy = real_t(0.5) * m1 * w2 * (du * du + dv * dv);
  const real_t energy = (m1 * pt.specific_energy(keep) + m2 * pt.specific_energy(gone) + relative_kinetic_energy) / m;
  // The merged domain: the mass-weighted mean shape, scaled to the two domains' total area.
  const real_t sx = w1 * pt.domain_stretch_x(keep) + w2 * pt.domain_stretch_x(gone);
  const real_t sy = w1 * pt.domain_stretch_y(keep) + w2 * pt.domain_stretch_y(gone);
  const real_t area = pt.domain_stretch_x(keep) * pt.domain_stretch_y(keep) +
                      pt.domain_stretch_x(gone) * pt.domain_stretch_y(gone);
  const real_t scale = square_root(area / (sx * sy));

  const real_t x = w1 * pt.position_x(keep) + w2 * pt.position_x(gone);
  const real_t y = w1 * pt.position_y(keep) + w2 * pt.position_y(gone);
  if (!boundaries.has_obstacles || boundaries.obstacles(x, y).distance > 0) {
    pt.position_x(keep) = x;
    pt.position_y(keep) = y;
  }
  pt.velocity_x(keep) = w1 * pt.velocity_x(keep) + w2 * pt.velocity_x(gone);
  pt.velocity_y(keep) = w1 * pt.velocity_y(keep) + w2 * pt.velocity_y(gone);
  pt.artificial_viscosity(keep) = w1 * pt.artificial_viscosity(keep) + w2 * pt.artificial_viscosity(gone);
  pt.mass(keep) = m;
  pt.density(keep) = m / volume;
  pt.specific_energy(keep) = energy;
  pt.domain_stretch_x(keep) = scale * sx;
  pt.domain_stretch_y(keep) = scale * sy;
  pt.mass(gone) = 0;
}

// A pair of a cell's candidates and its merge cost; first and second are their places in the cell's
// run of the candidates (in id order: first has the smaller id). (32-bit places: 16 bytes a pair,
// not 24, for the n (n - 1) / 2 pairs of a crowded cell.)
struct CandidatePair {
  real_t cost;
  std::uint32_t first, second;
};
// Cheapest first; equal costs in the order of the pair's ids: the same pairs in any particle order.
// A total order (no two pairs have the same places), so that any way of sorting gives one sequence.
bool cheaper(const CandidatePair& a, const CandidatePair& b) {
  if (a.cost != b.cost) return a.cost < b.cost;
  return a.first != b.first ? a.first < b.first : a.second < b.second;
}

// The pairs of one cell's candidates [begin, end) of `candidates` (sorted by id), into keep and
// gone. Level by level of costs equal to round-off (merge_tie_tolerance), the pairs of free
// particles taken, but not two that share a particle: of those none (a particle on a mirror line,
// its two nearest a mirror pair, would have merged with one of the two, breaking the symmetry; they
// may pair at a dearer level). A level starts at the cheapest pair of two particles still free and
// holds every pair within the tolerance of it.
//
// Incremental: the pairs are put in order a slice at a time (the cheapest of those not yet in
// order, as many as twice the free particles and at least 16), and once a slice is used up the
// pairs that hold a taken particle are dropped from the rest. Sorting all n (n - 1) / 2 pairs of a
// cell cost n^2 log n: the linear Mach 3 cylinder's early steps had up to 279 candidates in a cell,
// 61 000 pairs in a step, and their sort took 5 ms of a 30 ms step (README, Numerics, Merging). The
// first slices take most particles, and what is left of the pairs shrinks with the square of the
// free particles.
void pair_cell(const std::vector<MergeCandidate>& candidates, size_t begin, size_t end,
               std::vector<CandidatePair>& pairs, std::vector<char>& taken, std::vector<int>& claims,
               std::vector<index_t>& keep, std::vector<index_t>& gone) {
  const size_t count = end - begin;
  pairs.clear();
  for (size_t a = 0; a < count; ++a)
    for (size_t b = a + 1; b < count; ++b)
      pairs.push_back({merge_cost(candidates[begin + a], candidates[begin + b]), static_cast<std::uint32_t>(a),
                       static_cast<std::uint32_t>(b)});
  taken.assign(count, 0);
  claims.assign(count, 0);
  size_t free = count;
  // pairs[0, ordered) are in order, each cheaper than every pair after them.
  size_t ordered = 0;
  const auto order_through = [&](size_t k) {
    while (k >= ordered && ordered < pairs.size()) {
      const size_t slice_end = std::min(pairs.size(), ordered + std::max<size_t>(2 * free, 16));
      if (slice_end < pairs.size())
        std::nth_element(pairs.begin() + ordered, pairs.begin() + slice_end, pairs.end(), cheaper);
      std::sort(pairs.begin() + ordered, pairs.begin() + slice_end, cheaper);
      ordered = slice_end;
    }
    return k < pairs.size();
  };
  const auto holds_taken = [&](const CandidatePair& pair) { return taken[pair.first] || taken[pair.second]; };
  size_t next = 0;
  while (free >= 2) {
    if (next == ordered && next > 0) {  // the slice used up: the rest, less the pairs of taken particles
      pairs.erase(std::remove_if(pairs.begin() + next, pairs.end(), holds_taken), pairs.end());
      pairs.erase(pairs.begin(), pairs.begin() + next);
      next = ordered = 0;
    }
    if (!order_through(next)) break;
    if (holds_taken(pairs[next])) {
      ++next;
      continue;
    }
    const real_t level_cost = pairs[next].cost * (1 + merge_tie_tolerance);
    size_t level_end = next + 1;
    while (order_through(level_end) && pairs[level_end].cost <= level_cost) ++level_end;
    for (size_t k = next; k < level_end; ++k)
      if (!holds_taken(pairs[k])) ++claims[pairs[k].first], ++claims[pairs[k].second];
    // An uncontested pair's particles are claimed once (a taken particle is claimed by none).
    for (size_t k = next; k < level_end; ++k) {
      const CandidatePair& pair = pairs[k];
      if (claims[pair.first] != 1 || claims[pair.second] != 1) continue;
      taken[pair.first] = taken[pair.second] = 1;
      free -= 2;
      keep.push_back(candidates[begin + pair.first].index);
      gone.push_back(candidates[begin + pair.second].index);
    }
    for (size_t k = next; k < level_end; ++k) claims[pairs[k].first] = claims[pairs[k].second] = 0;
    next = level_end;
  }
}

}  // namespace

void pair_candidates(std::vector<MergeCandidate> candidates, std::vector<index_t>& keep, std::vector<index_t>& gone) {
  keep.clear();
  gone.clear();
  std::sort(candidates.begin(), candidates.end(), [](const MergeCandidate& a, const MergeCandidate& b) {
    return a.cell != b.cell ? a.cell < b.cell : a.id < b.id;
  });
  std::vector<CandidatePair> pairs;
  std::vector<char> taken;
  std::vector<int> claims;  // a level's pairs of free particles that claim each particle
  for (size_t begin = 0, end = 0; begin < candidates.size(); begin = end) {
    end = begin + 1;
    while (end < candidates.size() && candidates[end].cell == candidates[begin].cell) ++end;
    if (end - begin >= 2) pair_cell(candidates, begin, end, pairs, taken, claims, keep, gone);
  }
}

ParticleMerging::ParticleMerging(const CaseConfig& config, const GridGeometry& geometry)
    // Only split particles merge: without splitting there is nothing to look for.
    : enabled_(config.numerics.merge_particles && config.numerics.split_particles),
      initial_volume_(geometry.spacing_x * geometry.spacing_y /
                      (config.particles.per_cell_x * config.particles.per_cell_y)) {}

index_t ParticleMerging::merge(ParticleState& particles, const ParticleBoundaries& boundaries) const {
  if (!enabled_) return 0;
  const ParticleState pt = particles;
  const real_t initial_volume = initial_volume_;
  const IndexView candidates = select_indices(
      "merge_candidates", 0, pt.count,
      KOKKOS_LAMBDA(const index_t p) { return may_merge(pt.id(p), pt.mass(p), pt.density(p), initial_volume); },
      candidates_);
  const index_t num_candidates = static_cast<index_t>(candidates.extent(0));
  if (num_candidates < 2) return 0;

  // The pairs, on the host (pair_candidates). There are few candidates (tiny particles only):
  // their cells, ids, indices, positions and masses go to the host in two copies, the pairs and the
  // merged-away particles back in one, through buffers kept from step to step (merging runs every
  // step, and on a GPU an allocation costs more than these kernels).
  const size_t n = static_cast<size_t>(num_candidates);
  candidate_keys_.hold(3 * n, "merge_candidate_keys");
  candidate_places_.hold(3 * n, "merge_candidate_places");
  const ParticleIdView keys = candidate_keys_.part(3 * n);  // (cell, id, index) a candidate
  const RealView places = candidate_places_.part(3 * n);    // (x, y, mass) a candidate
  Kokkos::parallel_for(
      "merge_candidate_keys", Kokkos::RangePolicy<ExecutionSpace>(0, num_candidates), KOKKOS_LAMBDA(const index_t k) {
        const index_t p = candidates(k);
        keys(3 * k) = pt.cell(p);
        keys(3 * k + 1) = pt.id(p);
        keys(3 * k + 2) = p;
        places(3 * k) = pt.position_x(p);
        places(3 * k + 1) = pt.position_y(p);
        places(3 * k + 2) = pt.mass(p);
      });
  const auto keys_host = candidate_keys_.host_part(3 * n);
  const auto places_host = candidate_places_.host_part(3 * n);
  Kokkos::deep_copy(keys_host, keys);
  Kokkos::deep_copy(places_host, places);
  std::vector<MergeCandidate> listed(n);
  for (size_t k = 0; k < n; ++k)
    listed[k] = {keys_host(3 * k), keys_host(3 * k + 1), static_cast<index_t>(keys_host(3 * k + 2)),
                 places_host(3 * k), places_host(3 * k + 1), places_host(3 * k + 2)};
  std::vector<index_t> keep, gone;
  pair_candidates(listed, keep, gone);
  const index_t num_pairs = static_cast<index_t>(keep.size());
  if (num_pairs == 0) return 0;

  // keep, gone, and gone in increasing index order (the merged-away particles, as the compaction
  // wants them), one after the other.
  const size_t pairs = keep.size();
  pair_lists_.hold(3 * pairs, "merge_pair_lists");
  {
    const auto host = pair_lists_.host_part(3 * pairs);
    std::copy(keep.begin(), keep.end(), host.data());
    std::copy(gone.begin(), gone.end(), host.data() + pairs);
    std::sort(gone.begin(), gone.end());
    std::copy(gone.begin(), gone.end(), host.data() + 2 * pairs);
    Kokkos::deep_copy(pair_lists_.part(3 * pairs), host);
  }
  const auto list = [&](size_t k) {
    return Kokkos::subview(pair_lists_.device, std::make_pair(k * pairs, (k + 1) * pairs));
  };
  const IndexView keep_device = list(0), gone_device = list(1), removed = list(2);
  Kokkos::parallel_for(
      "merge_pairs", Kokkos::RangePolicy<ExecutionSpace>(0, num_pairs),
      KOKKOS_LAMBDA(const index_t k) { merge_pair(pt, keep_device(k), gone_device(k), boundaries); });

  const RealView mass = pt.mass;
  const HoleFilling plan = plan_hole_filling(
      pt.count, removed, KOKKOS_LAMBDA(const index_t p) { return mass(p) == real_t(0); }, fillers_);
  copy_particles("particle_fill_holes", particles, plan.holes, 0, plan.fillers, plan.count);
  particles.count = plan.staying;
  return num_pairs;
}

}  // namespace mpmflow
