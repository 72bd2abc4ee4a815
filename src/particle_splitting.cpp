#include "particle_splitting.hpp"

#include "kernels/particle_compaction.hpp"

#include <algorithm>
#include <string>
#include <vector>

namespace mpmflow {
namespace {

// Whether particle p splits: along which axis (split_axis), and where its halves would lie.
struct SplitRule {
  ParticleBoundaries boundaries;
  real_t initial_half_x, initial_half_y, initial_volume;

  // The axis (split_axis) and the half-length of the domain along it.
  KOKKOS_INLINE_FUNCTION int axis(const ParticleState& pt, index_t p, real_t& half_length) const {
    const int a = split_axis(pt.mass(p) / pt.density(p), initial_volume, pt.domain_stretch_x(p), pt.domain_stretch_y(p));
    half_length = a == 0 ? initial_half_x * pt.domain_stretch_x(p) : initial_half_y * pt.domain_stretch_y(p);
    return a;
  }
  // The centres of the two halves (the parent's and the new one's), kept in the domain.
  KOKKOS_INLINE_FUNCTION void halves(const ParticleState& pt, index_t p, int a, real_t half_length, real_t& x0,
                                     real_t& y0, real_t& x1, real_t& y1) const {
    x0 = x1 = pt.position_x(p);
    y0 = y1 = pt.position_y(p);
    (a == 0 ? x0 : y0) -= half_length / 2;
    (a == 0 ? x1 : y1) += half_length / 2;
    boundaries.domain.clamp(x0, y0);
    boundaries.domain.clamp(x1, y1);
  }
  // Splits where the domain is too wide, unless a half would lie in an obstacle.
  KOKKOS_INLINE_FUNCTION bool splits(const ParticleState& pt, index_t p) const {
    // Most particles are far below twice the initial volume: told so without the division (a
    // twentieth below the threshold, far more than round-off: exactly split_axis's answer).
    const real_t density = pt.density(p);
    if (density > 0 && pt.mass(p) < real_t(1.9) * initial_volume * density) return false;
    real_t half_length;
    const int a = axis(pt, p, half_length);
    if (a < 0) return false;
    if (!boundaries.has_obstacles) return true;
    real_t x0, y0, x1, y1;
    halves(pt, p, a, half_length, x0, y0, x1, y1);
    return boundaries.obstacles(x0, y0).distance > 0 && boundaries.obstacles(x1, y1).distance > 0;
  }
};

}  // namespace

ParticleSplitting::ParticleSplitting(const CaseConfig& config, const GridSlab& slab)
    : enabled_(config.numerics.split_particles),
      initial_half_x_(slab.geometry.spacing_x / (2 * config.particles.per_cell_x)),
      initial_half_y_(slab.geometry.spacing_y / (2 * config.particles.per_cell_y)),
      initial_volume_(slab.geometry.spacing_x * slab.geometry.spacing_y /
                      (config.particles.per_cell_x * config.particles.per_cell_y)) {}

long long ParticleSplitting::split(ParticleState& particles, const ParticleBoundaries& boundaries,
                                   const ParallelContext& context) {
  if (!enabled_) return 0;
  const SplitRule rule{boundaries, initial_half_x_, initial_half_y_, initial_volume_};
  const index_t count = particles.count;
  // The splitting particles in index order, counted and listed in one pass (select_indices, into
  // the list of the last splits, grown where it is too short). (In a scope of its own: `before`
  // holds every particle View, which would otherwise stay allocated beside its grown copy when the
  // halves make the Views grow below: all the particle fields twice, 77 B a particle more at the
  // peak.)
  index_t num_local = 0;
  {
    const ParticleState before = particles;
    num_local = static_cast<index_t>(
        select_indices(
            "split_list", 0, count, KOKKOS_LAMBDA(const index_t p) { return rule.splits(before, p); }, parent_)
            .extent(0));
  }
  const long long num_global = context.sum(static_cast<long long>(num_local));
  if (num_global == 0) return 0;

  // The halves' ids: -1 - 2 n and -2 - 2 n, n = splits so far + the rank of their parent's id among
  // all parents.
  // (In a View kept from step to step: splitting runs every step.)
  const size_t num_new = static_cast<size_t>(num_local);
  new_id_.hold(num_new, "split_new_id");
  const ParticleIdView new_id = new_id_.part(num_new);
  {
    const ParticleIdView id = particles.id;
    const IndexView parent = parent_;
    Kokkos::parallel_for(
        "split_parent_ids", Kokkos::RangePolicy<ExecutionSpace>(0, num_local),
        KOKKOS_LAMBDA(const index_t k) { new_id(k) = id(parent(k)); });
    const auto host = new_id_.host_part(num_new);
    Kokkos::deep_copy(host, new_id);
    std::vector<long long> local(host.data(), host.data() + num_local);
    std::vector<long long> all = context.all_gather(local);
    std::sort(all.begin(), all.end());
    for (index_t k = 0; k < num_local; ++k) {
      const long long rank = std::lower_bound(all.begin(), all.end(), local[static_cast<size_t>(k)]) - all.begin();
      host(k) = -1 - 2 * (splits_ + rank);
    }
    Kokkos::deep_copy(new_id, host);
  }

  // Append the halves as copies of their parents, then halve mass and domain and place both.
  particles.grow_to_hold(count + num_local);
  particles.count = count + num_local;
  const IndexView parent = parent_;
  copy_particles("split_copy", particles, IndexView(), count, parent, num_local);
  const ParticleState pt = particles;
  Kokkos::parallel_for(
      "split_halves", Kokkos::RangePolicy<ExecutionSpace>(0, num_local), KOKKOS_LAMBDA(const index_t k) {
        const index_t p = parent(k), q = count + k;
        real_t half_length;
        const int a = rule.axis(pt, p, half_length);
        real_t x0, y0, x1, y1;
        rule.halves(pt, p, a, half_length, x0, y0, x1, y1);
        pt.position_x(p) = x0, pt.position_y(p) = y0;
        pt.position_x(q) = x1, pt.position_y(q) = y1;
        pt.cell(p) = rule.boundaries.grid.cell_of(x0, y0);
        pt.cell(q) = rule.boundaries.grid.cell_of(x1, y1);
        pt.mass(p) *= real_t(0.5);
        pt.mass(q) = pt.mass(p);
        if (a == 0) {
          pt.domain_stretch_x(p) *= real_t(0.5);
          pt.domain_stretch_x(q) = pt.domain_stretch_x(p);
        } else {
          pt.domain_stretch_y(p) *= real_t(0.5);
          pt.domain_stretch_y(q) = pt.domain_stretch_y(p);
        }
        pt.id(p) = new_id(k);
        pt.id(q) = new_id(k) - 1;
      });
  splits_ += num_global;
  return num_global;
}

}  // namespace mpmflow
