#include "particle_merging.hpp"

#include <algorithm>
#include <numeric>
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

  // The pairs, on the host: the candidates in (cell, id) order, consecutive ones of a cell paired.
  // There are few candidates (tiny particles only): their cells, ids and indices go to the host in
  // one copy, the pairs and the merged-away particles back in one, through buffers kept from step
  // to step (merging runs every step, and on a GPU an allocation costs more than these kernels).
  const size_t n = static_cast<size_t>(num_candidates);
  candidate_keys_.hold(3 * n, "merge_candidate_keys");
  const ParticleIdView keys = candidate_keys_.part(3 * n);  // (cell, id, index) a candidate
  Kokkos::parallel_for(
      "merge_candidate_keys", Kokkos::RangePolicy<ExecutionSpace>(0, num_candidates), KOKKOS_LAMBDA(const index_t k) {
        const index_t p = candidates(k);
        keys(3 * k) = pt.cell(p);
        keys(3 * k + 1) = pt.id(p);
        keys(3 * k + 2) = p;
      });
  const auto keys_host = candidate_keys_.host_part(3 * n);
  Kokkos::deep_copy(keys_host, keys);
  const auto cell = [&](index_t k) { return keys_host(3 * k); };
  const auto id = [&](index_t k) { return keys_host(3 * k + 1); };
  const auto index = [&](index_t k) { return static_cast<index_t>(keys_host(3 * k + 2)); };
  std::vector<index_t> order(n);
  std::iota(order.begin(), order.end(), index_t(0));
  std::sort(order.begin(), order.end(), [&](index_t a, index_t b) {
    return cell(a) != cell(b) ? cell(a) < cell(b) : id(a) < id(b);
  });
  std::vector<index_t> keep, gone;
  for (size_t k = 0; k + 1 < order.size(); ++k) {
    if (cell(order[k]) != cell(order[k + 1])) continue;
    keep.push_back(index(order[k]));
    gone.push_back(index(order[k + 1]));
    ++k;
  }
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
