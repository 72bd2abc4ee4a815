#include "particle_merging.hpp"

#include <algorithm>
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

}  // namespace

void pair_candidates(std::vector<MergeCandidate> candidates, std::vector<index_t>& keep, std::vector<index_t>& gone) {
  keep.clear();
  gone.clear();
  std::sort(candidates.begin(), candidates.end(), [](const MergeCandidate& a, const MergeCandidate& b) {
    return a.cell != b.cell ? a.cell < b.cell : a.id < b.id;
  });
  struct Pair {
    real_t cost;
    size_t first, second;  // within the cell, in id order: first has the smaller id
  };
  std::vector<Pair> pairs;
  std::vector<char> taken;
  std::vector<int> claims;  // a level's pairs of free particles that claim each particle
  for (size_t begin = 0, end = 0; begin < candidates.size(); begin = end) {
    end = begin + 1;
    while (end < candidates.size() && candidates[end].cell == candidates[begin].cell) ++end;
    const size_t count = end - begin;
    if (count < 2) continue;
    pairs.clear();
    for (size_t a = begin; a < end; ++a)
      for (size_t b = a + 1; b < end; ++b) pairs.push_back({merge_cost(candidates[a], candidates[b]), a, b});
    // Cheapest first; equal costs in the order of the pair's ids (each pair's first id the smaller,
    // the candidates being in id order): the same pairs in any particle order.
    std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
      if (a.cost != b.cost) return a.cost < b.cost;
      return a.first != b.first ? a.first < b.first : a.second < b.second;
    });
    taken.assign(count, 0);
    claims.assign(count, 0);
    // Level by level of costs equal to round-off (merge_tie_tolerance), the pairs of free particles
    // taken, but not two that share a particle: of those none (a particle on a mirror line, its
    // two nearest a mirror pair, would have merged with one of the two, breaking the symmetry;
    // they may pair at a dearer level).
    for (size_t level = 0, level_end = 0; level < pairs.size(); level = level_end) {
      level_end = level + 1;
      while (level_end < pairs.size() && pairs[level_end].cost <= pairs[level].cost * (1 + merge_tie_tolerance))
        ++level_end;
      for (size_t k = level; k < level_end; ++k)
        if (!taken[pairs[k].first - begin] && !taken[pairs[k].second - begin])
          ++claims[pairs[k].first - begin], ++claims[pairs[k].second - begin];
      // An uncontested pair's particles are claimed once (a taken particle is claimed by none).
      for (size_t k = level; k < level_end; ++k) {
        const Pair& pair = pairs[k];
        if (claims[pair.first - begin] != 1 || claims[pair.second - begin] != 1) continue;
        taken[pair.first - begin] = taken[pair.second - begin] = 1;
        keep.push_back(candidates[pair.first].index);
        gone.push_back(candidates[pair.second].index);
      }
      for (size_t k = level; k < level_end; ++k) claims[pairs[k].first - begin] = claims[pairs[k].second - begin] = 0;
    }
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
