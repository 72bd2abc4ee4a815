#include "particle_splitting.hpp"

#include "kernels/particle_compaction.hpp"

#include <algorithm>
#include <string>
#include <vector>

namespace mpmflow {
namespace {

// Whether particle p splits: along which axis (split_axis), and where its pieces would lie.
struct SplitRule {
  ParticleBoundaries boundaries;
  real_t initial_half_x, initial_half_y, initial_volume;
  real_t cell_x, cell_y;

  KOKKOS_INLINE_FUNCTION int axis(const ParticleState& pt, index_t p) const {
    return split_axis(pt.mass(p) / pt.density(p), initial_volume, pt.domain_stretch_x(p), pt.domain_stretch_y(p));
  }
  // The centres of the pieces of a split along `a` (split_pieces(a) of them; the first the parent's),
  // each the centre of its share of the parent's domain, but at most a cell from the parent's
  // centre, and kept in the domain. Gas sheared along a body stretches domains into needles along
  // the flow (42 times their placed length along the transonic aerofoil), far beyond the cell the
  // GIMP weights see of them; pieces at the centres of such a needle's halves carried the mass of
  // a wake particle many cells away: split particles upstream of the Mach 3 cylinder (2 to 24 ahead
  // of x = 0.3 at each of six outputs, seeds 1 and 2) and at its nose, where they heated in the
  // dense shock layer (specific energies up to 190; the stagnation energy is 5.0); at most a cell
  // away, none upstream and the nose's hottest at 5 to 9 (README, Status).
  KOKKOS_INLINE_FUNCTION void pieces(const ParticleState& pt, index_t p, int a, real_t (&x)[4], real_t (&y)[4]) const {
    const real_t quarter_x = initial_half_x * pt.domain_stretch_x(p) / 2;  // of the domain's length
    const real_t quarter_y = initial_half_y * pt.domain_stretch_y(p) / 2;
    const real_t reach_x = quarter_x < cell_x ? quarter_x : cell_x, reach_y = quarter_y < cell_y ? quarter_y : cell_y;
    const real_t offset_x = a == 1 ? real_t(0) : reach_x, offset_y = a == 0 ? real_t(0) : reach_y;
    const int n = split_pieces(a);
    for (int k = 0; k < n; ++k) {
      // Along one axis: -, +. Along both: (-, -), (+, -), (-, +), (+, +).
      const int along_x = a == 1 ? 0 : (k % 2 == 0 ? -1 : 1);
      const int along_y = a == 0 ? 0 : a == 1 ? (k % 2 == 0 ? -1 : 1) : (k < 2 ? -1 : 1);
      x[k] = pt.position_x(p) + along_x * offset_x;
      y[k] = pt.position_y(p) + along_y * offset_y;
      boundaries.domain.clamp(x[k], y[k]);
    }
  }
  // Splits where the domain is too wide, unless a piece would lie in an obstacle.
  KOKKOS_INLINE_FUNCTION bool splits(const ParticleState& pt, index_t p) const {
    // Most particles are far below twice the initial volume: told so without the division (a
    // twentieth below the threshold, far more than round-off: exactly split_axis's answer).
    const real_t density = pt.density(p);
    if (density > 0 && pt.mass(p) < real_t(1.9) * initial_volume * density) return false;
    const int a = axis(pt, p);
    if (a < 0) return false;
    if (!boundaries.has_obstacles) return true;
    real_t x[4], y[4];
    pieces(pt, p, a, x, y);
    for (int k = 0; k < split_pieces(a); ++k)
      if (!(boundaries.obstacles(x[k], y[k]).distance > 0)) return false;
    return true;
  }
};

}  // namespace

ParticleSplitting::ParticleSplitting(const CaseConfig& config, const GridSlab& slab)
    : enabled_(config.numerics.split_particles),
      initial_half_x_(slab.geometry.spacing_x / (2 * config.particles.per_cell_x)),
      initial_half_y_(slab.geometry.spacing_y / (2 * config.particles.per_cell_y)),
      initial_volume_(slab.geometry.spacing_x * slab.geometry.spacing_y /
                      (config.particles.per_cell_x * config.particles.per_cell_y)),
      cell_x_(slab.geometry.spacing_x),
      cell_y_(slab.geometry.spacing_y) {}

long long ParticleSplitting::split(ParticleState& particles, const ParticleBoundaries& boundaries,
                                   const ParallelContext& context) {
  if (!enabled_) return 0;
  const SplitRule rule{boundaries, initial_half_x_, initial_half_y_, initial_volume_, cell_x_, cell_y_};
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
  // The pieces' ids: -1 - 2 n and below, n = splits so far + the rank of their parent's id among all
  // parents, a parent splitting in four counted twice; and where each parent's new pieces go among
  // the appended particles.
  // (In Views kept from step to step: splitting runs every step.)
  const size_t num_parents = static_cast<size_t>(num_local);
  const IndexView parent = parent_;
  std::vector<long long> local;  // this rank's parents' ids, one a split
  if (num_parents > 0) {
    new_id_.hold(num_parents, "split_new_id");
    first_new_.hold(num_parents, "split_first_new");
    const ParticleIdView new_id = new_id_.part(num_parents);
    const IndexView first_new = first_new_.part(num_parents);
    const ParticleState before = particles;
    Kokkos::parallel_for(
        "split_parent_ids", Kokkos::RangePolicy<ExecutionSpace>(0, num_local), KOKKOS_LAMBDA(const index_t k) {
          new_id(k) = before.id(parent(k));
          first_new(k) = split_pieces(rule.axis(before, parent(k))) - 1;  // its new pieces, for now
        });
    const auto host_id = new_id_.host_part(num_parents);
    const auto host_first = first_new_.host_part(num_parents);
    Kokkos::deep_copy(host_id, new_id);
    Kokkos::deep_copy(host_first, first_new);
    local.reserve(2 * num_parents);
    for (size_t k = 0; k < num_parents; ++k) {
      local.push_back(host_id(k));
      // A split in four numbers two splits.
      if (host_first(k) == split_pieces(split_both_axes) - 1) local.push_back(host_id(k));
    }
  }
  // Every rank's, in one exchange (empty where no particle splits anywhere: no count summed over
  // the ranks first, a collective a step fewer).
  std::vector<long long> all = context.all_gather(local);
  if (all.empty()) return 0;
  const ParticleIdView new_id = new_id_.part(num_parents);
  const IndexView first_new = first_new_.part(num_parents);
  index_t num_new = 0;
  long long splits_made = 0;
  {
    const auto host_id = new_id_.host_part(num_parents);
    const auto host_first = first_new_.host_part(num_parents);
    std::sort(all.begin(), all.end());
    for (size_t k = 0; k < num_parents; ++k) {
      const long long rank = std::lower_bound(all.begin(), all.end(), host_id(k)) - all.begin();
      host_id(k) = -1 - 2 * (splits_ + rank);
      const index_t pieces_added = host_first(k);
      host_first(k) = num_new;
      num_new += pieces_added;
    }
    Kokkos::deep_copy(new_id, host_id);
    Kokkos::deep_copy(first_new, host_first);
    splits_made = static_cast<long long>(all.size());
    splits_ += splits_made;
  }

  // Append the new pieces as copies of their parents, then share out mass and domain and place them.
  // (Copied parent by parent: a list of each new piece's parent would hold memory at the growth's
  // peak, GrowingForTheHalvesHoldsNoFieldTwiceButTheOneBeingMoved.)
  particles.grow_to_hold(count + num_new);
  particles.count = count + num_new;
  {
    const WholeParticles whole(particles);
    Kokkos::parallel_for(
        "split_copy", Kokkos::RangePolicy<ExecutionSpace>(0, num_local), KOKKOS_LAMBDA(const index_t k) {
          const index_t end = k + 1 < num_local ? first_new(k + 1) : num_new;
          for (index_t j = first_new(k); j < end; ++j) whole.copy(count + j, parent(k));
        });
  }
  const ParticleState pt = particles;
  Kokkos::parallel_for(
      "split_pieces", Kokkos::RangePolicy<ExecutionSpace>(0, num_local), KOKKOS_LAMBDA(const index_t k) {
        const index_t p = parent(k);
        const int a = rule.axis(pt, p), n = split_pieces(a);
        real_t x[4], y[4];
        rule.pieces(pt, p, a, x, y);
        const real_t mass = pt.mass(p) / n;
        const real_t stretch_x = a == 1 ? pt.domain_stretch_x(p) : pt.domain_stretch_x(p) * real_t(0.5);
        const real_t stretch_y = a == 0 ? pt.domain_stretch_y(p) : pt.domain_stretch_y(p) * real_t(0.5);
        for (int j = 0; j < n; ++j) {
          const index_t q = j == 0 ? p : count + first_new(k) + j - 1;
          pt.position_x(q) = x[j], pt.position_y(q) = y[j];
          pt.cell(q) = rule.boundaries.grid.cell_of(x[j], y[j]);
          pt.mass(q) = mass;
          pt.domain_stretch_x(q) = stretch_x;
          pt.domain_stretch_y(q) = stretch_y;
          pt.id(q) = new_id(k) - j;
        }
      });
  return splits_made;
}

}  // namespace mpmflow
