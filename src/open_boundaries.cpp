#include "open_boundaries.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "gas_physics.hpp"

#include "kernels/index_lanes.hpp"
#include "kernels/particle_compaction.hpp"
#include "kernels/reductions.hpp"

namespace mpmflow {
namespace {

// Whether a particle has left the domain, through a side that is open (the particle boundaries
// keep particles inside at walls and obstacles, and mark those outside: its cell).
struct LeftTheDomain {
  IndexView cell;
  KOKKOS_INLINE_FUNCTION bool operator()(const index_t p) const { return cell(p) == left_the_domain; }
};

// Rows r >= 0 of a lattice column at phase `phase` (in row spacings) that lie within `rows`
// row spacings of the side: those entered once the lattice has moved that far.
KOKKOS_INLINE_FUNCTION long long rows_entered(double rows, double phase) {
  const double x = rows + 1 - phase;  // > 0
  return static_cast<long long>(x);   // floor for x > 0
}

// The share of the strip of a side's cell c (one cell deep along the side, `depth_of_strip`) that
// its lattice already covers, the lattice having moved `distance`: each column's next row, o
// outside the side, reaches l - o inside with its half extent l, half a row spacing. The strip
// volume leaves that part out, and it is no gap: the gas outside is already there.
double lattice_cover_of_strip(const EntrySide& side, index_t c, double distance, double depth_of_strip) {
  const double l = side.row_spacing / 2;
  double cover = 0;
  for (int k = 0; k < side.per_cell_along; ++k) {
    const double phase = (c * side.per_cell_along + k + 0.5) / side.columns;
    const double outside = (rows_entered(distance / side.row_spacing, phase) + phase) * side.row_spacing - distance;
    cover += std::max(0.0, l - outside);
  }
  return cover / (side.per_cell_along * depth_of_strip);
}

// One step's candidates for entering through one side: (row offset q, column i) for q < max_rows.
struct EntryCandidates {
  EntrySide side;
  Kokkos::View<const double*, DeviceType> distance_before, distance_after, inward_speed;  // per cell, the side's
  DomainBox domain;
  GridSlab slab;  // ownership of the cells
  DeviceObstacleSet obstacles;
  bool has_obstacles;
  bool random;
  std::uint64_t seed;
  particle_id_t id_base, max_columns;
  GasState free_stream;
  real_t specific_energy, particle_mass;

  // Whether candidate k enters this rank during the step; if so its id, position and inward
  // normal speed.
  KOKKOS_INLINE_FUNCTION bool enters(const index_t k, particle_id_t& id, real_t& x, real_t& y, real_t& speed) const {
    const index_t i = k % side.columns;
    const long long q = k / side.columns;
    const index_t cell = i / side.per_cell_along;
    const double phase = (i + 0.5) / side.columns;
    const long long first_row = rows_entered(distance_before(cell) / side.row_spacing, phase);
    const long long row = first_row + q;
    if (row >= rows_entered(distance_after(cell) / side.row_spacing, phase)) return false;
    id = id_base + (row * num_sides + side.side) * max_columns + i;
    double depth = distance_after(cell) - (row + phase) * side.row_spacing;  // >= 0 up to round-off
    double along = (i + 0.5) * side.column_width;
    if (random) {
      depth += (counter_uniform(seed, static_cast<std::uint64_t>(id), 0, 0) - 0.5) * side.row_spacing;
      along += (counter_uniform(seed, static_cast<std::uint64_t>(id), 0, 1) - 0.5) * side.column_width;
    }
    depth = depth < 0 ? -depth : depth;  // reflected at the side (and round-off)
    domain.point_inside_side(side.side, real_t(along), real_t(depth), x, y);
    if (has_obstacles && obstacles(x, y).distance <= 0) return false;
    const index_t owned_cell = slab.global_cell_along(slab.axis, x, y);
    const index_t owned_begin = slab.axis == 0 ? slab.owned_cell_begin_x : slab.owned_cell_begin_y;
    const index_t owned_end = slab.axis == 0 ? slab.owned_cell_end_x : slab.owned_cell_end_y;
    if (owned_cell < owned_begin || owned_cell >= owned_end) return false;
    speed = side.far_field ? real_t(inward_speed(cell)) : real_t(side.free_stream_inward);
    return true;
  }
};

// Counts the candidates that enter this rank.
struct CountEntering {
  EntryCandidates candidates;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, index_t& n) const {
    particle_id_t id;
    real_t x, y, speed;
    if (candidates.enters(k, id, x, y, speed)) ++n;
  }
};

// Appends the entering particles at index `first` on, in candidate order.
struct AppendEntering {
  EntryCandidates candidates;
  ParticleState pt;
  index_t first;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, index_t& offset, const bool final) const {
    particle_id_t id;
    real_t x, y, speed;
    if (!candidates.enters(k, id, x, y, speed)) return;
    if (final) {
      const index_t p = first + offset;
      const GasState& s = candidates.free_stream;
      real_t nx, ny;
      inward_normal(candidates.side.side, nx, ny);
      // The free stream's tangential velocity and the inward normal speed.
      const real_t v_normal = s.velocity_x * nx + s.velocity_y * ny;
      const real_t vx = s.velocity_x + (speed - v_normal) * nx, vy = s.velocity_y + (speed - v_normal) * ny;
      set_free_stream_particle(pt, p, candidates.slab.geometry, x, y, vx, vy, s, candidates.specific_energy,
                               candidates.particle_mass);
      pt.id(p) = id;
    }
    ++offset;
  }
};

// speed(c): the inward normal velocity of the gas at each cell c along a far-field side that this
// rank owns (the mean of V-bar on the cell's two side nodes; negative where the gas leaves), 0 at
// the cells of other ranks.
void far_field_inward_speed(const EntrySide& side, const SlabState& slab_state,
                            const Kokkos::View<double*, DeviceType>& speed) {
  fill_in_order(speed, 0.0);
  const GridSlab& slab = slab_state.slab();
  const GridGeometry geo = slab.geometry;
  const NodeFieldsView velocity = slab_state.fields().per_unit_mass;
  const int s = side.side;
  const bool along_x = s == bottom_side || s == top_side;
  // The side's global cell and node line across it, and this slab's cells along it.
  const index_t cell_across = (s == left_side || s == bottom_side) ? 0 : slab.global_cells(along_x ? 1 : 0) - 1;
  const index_t node_across = (s == left_side || s == bottom_side) ? 0 : slab.global_cells(along_x ? 1 : 0);
  const IndexRange2D owned = slab.index_space(Ownership::owned, Entity::cell, Indexing::global);
  const int across_axis = along_x ? 1 : 0;
  if (cell_across < owned.begin(across_axis) || cell_across >= owned.end(across_axis)) return;
  const index_t first = owned.begin(along_x ? 0 : 1), last = owned.end(along_x ? 0 : 1);
  const index_t offset_x = slab.node_offset_x, offset_y = slab.node_offset_y;
  Kokkos::parallel_for(
      "far_field_inward_speed", Kokkos::RangePolicy<ExecutionSpace>(first, last), KOKKOS_LAMBDA(const index_t c) {
        double sum = 0;
        for (index_t end = 0; end < 2; ++end) {
          const index_t gi = along_x ? c + end : node_across, gj = along_x ? node_across : c + end;
          const index_t node = geo.node_index(gi - offset_x, gj - offset_y);
          sum += inward_speed(s, velocity(node, GridFields::velocity_x), velocity(node, GridFields::velocity_y));
        }
        speed(c) = sum / 2;
      });
}

// The volume m / rho of this rank's particles in the strip one cell deep along a far-field side,
// per cell along it, in units of the cell's area / 2^32. Integers: their sums over particles and
// ranks are exact in any order, so the decisions made from them do not depend on the threads,
// the ranks or the particle order.
constexpr double strip_volume_unit = 1.0 / 4294967296.0;  // of a cell's area

// The far-field sides whose strips one pass over the particles measures (at most four).
struct FarFieldStrips {
  int count = 0;
  Kokkos::Array<int, num_sides> side;
  Kokkos::Array<index_t, num_sides> first_cell, cells;  // the side's cells in the entry-cell arrays
  Kokkos::Array<real_t, num_sides> half_row;  // half the side's row spacing: a particle's half extent across it
  Kokkos::Array<bool, num_sides> at{};  // by Side: whether that side is one of them
};

// Adds the strip volumes of particles [first, last) to `volume`, for every far-field side at once,
// at volume(side.first_cell + c): one read of the positions for all sides, and of the mass and
// density only for the particles within a strip. Most particles lie in no strip: a test of the
// four depths at once, in vector lanes, tells them, before the sides are taken one by one (as a
// loop over the sides alone, the pass took 1.3 times as long as the three passes of one side each
// that it replaced).
void add_far_field_strip_volumes(const FarFieldStrips& strips, const ParticleState& pt, index_t first, index_t last,
                                 const GridSlab& slab, const Kokkos::View<long long*, DeviceType>& volume,
                                 KeptScatterView<long long>& kept_scatter) {
  if (strips.count == 0 || first >= last) return;
  const DomainBox domain(slab);
  const real_t hx = slab.geometry.spacing_x, hy = slab.geometry.spacing_y;
  const real_t reach_x = real_t(1.5) * hx, reach_y = real_t(1.5) * hy;  // (a half row is at most half a cell)
  const double units_per_volume = 1.0 / (double(slab.cell_area()) * strip_volume_unit);
  const RealView x = pt.position_x, y = pt.position_y, mass = pt.mass, density = pt.density;
  const auto scatter = kept_scatter.into(volume);
  for_each_index_where(
      "far_field_strip_volume", first, last,
      KOKKOS_LAMBDA(const index_t p) {  // a superset of the strips below: depth < 1.5 depth_of_strip, whatever its sign
        const real_t xp = x(p), yp = y(p);
        return (strips.at[left_side] & (xp - domain.x_min < reach_x)) |
               (strips.at[right_side] & (domain.x_max - xp < reach_x)) |
               (strips.at[bottom_side] & (yp - domain.y_min < reach_y)) |
               (strips.at[top_side] & (domain.y_max - yp < reach_y));
      },
      KOKKOS_LAMBDA(const index_t p) {
        const real_t xp = x(p), yp = y(p);
        for (int k = 0; k < strips.count; ++k) {
          const int s = strips.side[k];
          const bool along_x = s == bottom_side || s == top_side;
          const real_t depth_of_strip = along_x ? hy : hx, width = along_x ? hx : hy;
          real_t depth, along;
          domain.depth_and_along_side(s, xp, yp, depth, along);
          // The share of the particle's extent across the side, a row spacing, within the strip:
          // a row of particles crossing the strip's inner edge leaves it gradually, not all at once
          // (where the gas moves inwards, counting whole particles by their centres had the strip
          // half empty each time a row left it and the next had not come far enough in).
          const real_t l = strips.half_row[k];
          const real_t low = depth - l > 0 ? depth - l : real_t(0);
          const real_t high = depth + l < depth_of_strip ? depth + l : depth_of_strip;
          if (!(depth >= 0 && high > low)) continue;
          const double share = double(high - low) / double(2 * l);
          const index_t cells = strips.cells[k];
          index_t c = static_cast<index_t>(along / width);
          c = c < 0 ? 0 : (c >= cells ? cells - 1 : c);
          auto access = scatter.access();
          access(strips.first_cell[k] + c) +=
              static_cast<long long>(share * double(mass(p)) / double(density(p)) * units_per_volume + 0.5);
        }
      });
  kept_scatter.contribute_into(volume);
}

// The sums of totals_of_particles in one reduction (one launch, and one wait for its result on a
// GPU, where there were five), each total summed in the order its own reduction summed it: the
// same bits.
struct ParticleTotalsSum {
  using value_type = double[];
  enum Total : int { mass, momentum_x, momentum_y, kinetic_energy, internal_energy, num_totals };
  unsigned value_count = num_totals;  // (Kokkos' name: the length of an array reduction)
  RealView m, vx, vy, e;
  IndexView list;  // the particles summed, or (empty) first + k
  index_t first;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, value_type totals) const {
    const index_t p = list.extent(0) > 0 ? list(k) : first + k;
    const double particle_mass = m(p);
    totals[mass] += particle_mass;
    totals[momentum_x] += particle_mass * vx(p);
    totals[momentum_y] += particle_mass * vy(p);
    totals[kinetic_energy] += 0.5 * particle_mass * (double(vx(p)) * vx(p) + double(vy(p)) * vy(p));
    totals[internal_energy] += particle_mass * e(p);
  }
};

}  // namespace

ConservationTotals totals_of_particles(const ParticleState& pt, const IndexView& list, index_t first, index_t count) {
  ConservationTotals totals;
  if (count == 0) return totals;
  using Sum = ParticleTotalsSum;
  double sums[Sum::num_totals] = {};
  sum_in_fixed_order("open_side_totals", count,
                     Sum{Sum::num_totals, pt.mass, pt.velocity_x, pt.velocity_y, pt.specific_energy, list, first}, sums);
  totals.mass = sums[Sum::mass];
  totals.momentum_x = sums[Sum::momentum_x];
  totals.momentum_y = sums[Sum::momentum_y];
  totals.kinetic_energy = sums[Sum::kinetic_energy];
  totals.internal_energy = sums[Sum::internal_energy];
  return totals;
}

size_t OpenBoundaries::num_entry_cells(const CaseConfig& config) {
  if (config.boundaries.particle_supply != ParticleSupply::open) return 0;
  size_t cells = 0;
  const auto types = acting_boundaries(config).side_types();
  for (int s = 0; s < num_sides; ++s)
    if (types[s] == BoundaryType::inflow || types[s] == BoundaryType::far_field)
      cells += (s == bottom_side || s == top_side) ? config.domain.cells_x : config.domain.cells_y;
  return cells;
}

OpenBoundaries::OpenBoundaries(const CaseConfig& config, const GridSlab& slab)
    : supply_(config.boundaries.particle_supply),
      any_open_(config.boundaries.any_open()),
      random_placement_(config.particles.placement == ParticlePlacement::random),
      seed_(config.particles.seed),
      free_stream_(config.boundaries.free_stream) {
  const index_t per_cell = config.particles.per_cell_x * config.particles.per_cell_y;
  specific_energy_ = perfect_gas_specific_energy(config.physics.gamma, free_stream_.density, free_stream_.pressure);
  // As create_initial_particles computes it, so that entering and initial particles weigh the same.
  particle_mass_ = free_stream_.density * (slab.cell_area() / per_cell);
  id_base_ = static_cast<particle_id_t>(slab.global_cells_x) * slab.global_cells_y * per_cell;
  max_columns_ = std::max<particle_id_t>(static_cast<particle_id_t>(slab.global_cells_x) * config.particles.per_cell_x,
                                         static_cast<particle_id_t>(slab.global_cells_y) * config.particles.per_cell_y);
  const auto types = acting_boundaries(config).side_types();

  // Recycling: the inflow sides end to end.
  recycle_.domain = DomainBox(slab);
  real_t length = 0;
  for (int s = 0; s < num_sides; ++s) {
    if (types[s] != BoundaryType::inflow) continue;
    const bool x_normal = s == left_side || s == right_side;
    length += x_normal ? (slab.domain_y_max - slab.domain_y_min) : (slab.domain_x_max - slab.domain_x_min);
    const int k = recycle_.num_inflow_sides++;
    recycle_.inflow_side[k] = s;
    recycle_.inflow_length_end[k] = length;
    recycle_.inward_speed[k] = inward_speed(s, free_stream_.velocity_x, free_stream_.velocity_y);
    recycle_.cell_depth[k] = x_normal ? slab.geometry.spacing_x : slab.geometry.spacing_y;
  }
  recycle_.free_stream = free_stream_;
  recycle_.specific_energy = specific_energy_;
  recycle_.seed = seed_;

  // Entering: the lattice outside each inflow and far-field side.
  if (supply_ != ParticleSupply::open) return;
  const DomainConfig& d = config.domain;
  const double hx = (double(d.x_max) - d.x_min) / d.cells_x, hy = (double(d.y_max) - d.y_min) / d.cells_y;
  index_t first_cell = 0;
  for (int s = 0; s < num_sides; ++s) {
    if (types[s] != BoundaryType::inflow && types[s] != BoundaryType::far_field) continue;
    const bool along_x = s == bottom_side || s == top_side;
    EntrySide side;
    side.side = s;
    side.far_field = types[s] == BoundaryType::far_field;
    side.cells = along_x ? d.cells_x : d.cells_y;
    side.first_cell = first_cell;
    side.per_cell_along = along_x ? config.particles.per_cell_x : config.particles.per_cell_y;
    side.columns = side.cells * side.per_cell_along;
    side.row_spacing = along_x ? hy / config.particles.per_cell_y : hx / config.particles.per_cell_x;
    side.column_width = along_x ? hx / config.particles.per_cell_x : hy / config.particles.per_cell_y;
    side.free_stream_inward = inward_speed(s, free_stream_.velocity_x, free_stream_.velocity_y);
    side.fills_strip = side.far_field && !far_field_inlet(types[s], real_t(side.free_stream_inward));
    sides_.push_back(side);
    first_cell += side.cells;
  }
  entry_distance_.assign(static_cast<size_t>(first_cell), 0.0);
  entry_cells_ = Kokkos::View<double*, DeviceType>("entry_cells", 3 * static_cast<size_t>(first_cell));
  entry_cells_host_ = host_mirror(entry_cells_);
  strip_volume_ = Kokkos::View<long long*, DeviceType>("far_field_strip_volume", first_cell);
  strip_volume_host_ = host_mirror(strip_volume_);
}

void OpenBoundaries::restore(const std::vector<double>& entry_distance, const BoundaryFluxes& fluxes) {
  entry_distance_ = entry_distance;
  fluxes_ = fluxes;
}

void OpenBoundaries::exchange(ParticleState& pt, const SlabState& slab_state, real_t dt, long step) {
  if (!any_open_) return;
  {
    // The particles that have left. (In a scope of its own: `outside` holds the cell View, which
    // would otherwise stay allocated beside its grown copy when the gas entering below makes the
    // particle Views grow.)
    const LeftTheDomain outside{pt.cell};
    const IndexView leaving = select_indices("open_side_leaving", 0, pt.count, outside, leaving_);
    const index_t num_leaving = static_cast<index_t>(leaving.extent(0));
    fluxes_.left += totals_of_particles(pt, leaving, 0, num_leaving);
    if (supply_ == ParticleSupply::recycle) {
      recycle(pt, slab_state, leaving, dt, step);
      return;
    }
    // Open: they are removed ...
    if (num_leaving > 0) {
      const HoleFilling plan = plan_hole_filling(pt.count, leaving, outside, fillers_);
      copy_particles("particle_fill_holes", pt, plan.holes, 0, plan.fillers, plan.count);
      pt.count = plan.staying;
    }
  }
  // ... and the free stream enters.
  enter(pt, slab_state, dt);
}

void OpenBoundaries::recycle(ParticleState& pt, const SlabState& slab_state, const IndexView& leaving, real_t dt,
                             long step) {
  const index_t num_leaving = static_cast<index_t>(leaving.extent(0));
  if (num_leaving == 0) return;
  Recycle recycle = recycle_;
  for (int k = 0; k < recycle.num_inflow_sides; ++k) {
    const real_t swept = recycle.inward_speed[k] * dt;
    recycle.strip_depth[k] = swept > 0 ? std::min(swept, recycle.cell_depth[k]) : recycle.cell_depth[k];
  }
  recycle.obstacles = slab_state.obstacles().obstacles;
  recycle.has_obstacles = !slab_state.obstacles().obstacles.empty();
  recycle.step = static_cast<std::uint64_t>(step);
  recycle.grid = slab_state.geometry();
  recycle.list = leaving;
  recycle.pt = pt;
  Kokkos::parallel_for("recycle", Kokkos::RangePolicy<ExecutionSpace>(0, num_leaving), recycle);
  fluxes_.entered += totals_of_particles(pt, leaving, 0, num_leaving);
}

void OpenBoundaries::enter(ParticleState& pt, const SlabState& slab_state, real_t dt) {
  const GridSlab& slab = slab_state.slab();
  const ObstacleGrid& obstacles = slab_state.obstacles();
  // Every far-field strip's volume in one pass; the particles that an earlier side lets in during
  // this loop are added before a later side reads its strips, as a pass of each side's own did.
  FarFieldStrips strips;
  for (const EntrySide& side : sides_) {
    if (!side.fills_strip) continue;
    strips.at[side.side] = true;
    strips.side[strips.count] = side.side;
    strips.first_cell[strips.count] = side.first_cell;
    strips.cells[strips.count] = side.cells;
    strips.half_row[strips.count] = side.row_spacing / 2;
    ++strips.count;
  }
  if (strips.count > 0) {  // (no far-field side, as in the cylinder: nothing to zero every step)
    fill_in_order(strip_volume_, 0LL);
    add_far_field_strip_volumes(strips, pt, 0, pt.count, slab, strip_volume_, strip_volume_scatter_);
  }
  index_t measured = pt.count;  // particles [0, measured) are in strip_volume_
  for (const EntrySide& side : sides_) {
    const auto cells = std::make_pair(side.first_cell, side.first_cell + side.cells);
    // The side's block of entry_cells_: its cells' distances before and after the step and inward
    // speeds, one after the other, so that one copy takes them to the device.
    const size_t n = static_cast<size_t>(side.cells), block_begin = 3 * static_cast<size_t>(side.first_cell);
    const auto block = std::make_pair(block_begin, block_begin + 3 * n);
    const auto part = [&](const auto& view, size_t k) {
      return Kokkos::subview(view, std::make_pair(block.first + k * n, block.first + (k + 1) * n));
    };
    const auto before = part(entry_cells_host_, 0), after = part(entry_cells_host_, 1),
               speed = part(entry_cells_host_, 2);
    // The gap each cell's strip next to a far-field side needs filled (in lengths along the normal).
    std::vector<double> fill(n, 0.0);
    if (side.far_field) {
      const auto side_speed = part(entry_cells_, 2);
      far_field_inward_speed(side, slab_state, side_speed);
      Kokkos::deep_copy(speed, side_speed);
      slab_state.context().sum_in_place(speed.data(), static_cast<int>(side.cells));
    }
    // Not where the free stream enters (an inlet): the lattice moves in with the gas there, and the
    // gas outside acts on what the particles leave uncovered (SidePressure). A fill there answered
    // each gap that the stream's motion along the side opened against the lattice's fixed columns,
    // and took nothing back: the diagonal stream of WindTunnel.AStreamCrossingFarFieldSidesKeepsItsState
    // gained 10.6 % of its mass by t = 3.
    if (side.fills_strip) {
      add_far_field_strip_volumes(strips, pt, measured, pt.count, slab, strip_volume_, strip_volume_scatter_);
      measured = pt.count;
      const auto volume = Kokkos::subview(strip_volume_host_, cells);
      Kokkos::deep_copy(volume, Kokkos::subview(strip_volume_, cells));
      slab_state.context().sum_in_place(volume.data(), static_cast<int>(side.cells));
      const bool along_x = side.side == bottom_side || side.side == top_side;
      const double depth_of_strip = along_x ? slab.geometry.spacing_y : slab.geometry.spacing_x;
      for (size_t c = 0; c < n; ++c) {
        // Where the gas does not leave, the free stream outside fills what the particles leave
        // empty of the strip (see the header).
        const double empty = 1.0 - double(volume(c)) * strip_volume_unit -
                             lattice_cover_of_strip(side, static_cast<index_t>(c),
                                                    entry_distance_[static_cast<size_t>(side.first_cell) + c],
                                                    depth_of_strip);
        if (speed(c) >= 0 && empty > 0) fill[c] = empty * depth_of_strip;
      }
    }
    if (!side.far_field)
      for (size_t c = 0; c < n; ++c) speed(c) = side.free_stream_inward;
    double largest_advance = 0;
    for (size_t c = 0; c < n; ++c) {
      if (speed(c) < 0) speed(c) = 0;  // where the gas leaves, the lattice waits
      double& distance = entry_distance_[static_cast<size_t>(side.first_cell) + c];
      before(c) = distance;
      // The lattice moves in with the gas, or further where that does not fill the strip (the gas
      // that moved in during the step is part of the strip's emptiness measured before it enters).
      distance += std::max(speed(c) * dt, fill[c]);
      after(c) = distance;
      largest_advance = std::max(largest_advance, after(c) - before(c));
    }
    if (largest_advance <= 0) continue;
    // Rows entering a column in one step: at most the advance in row spacings, rounded up, + 1.
    const long long max_rows = static_cast<long long>(largest_advance / side.row_spacing) + 2;
    const long long num_candidates = max_rows * side.columns;
    if (num_candidates > static_cast<long long>(std::numeric_limits<index_t>::max()))
      throw std::runtime_error("open boundaries: the step of " + std::to_string(dt) +
                               " moves the free stream over too many particle rows at once");
    Kokkos::deep_copy(Kokkos::subview(entry_cells_, block), Kokkos::subview(entry_cells_host_, block));

    EntryCandidates candidates;
    candidates.side = side;
    candidates.distance_before = part(entry_cells_, 0);
    candidates.distance_after = part(entry_cells_, 1);
    candidates.inward_speed = part(entry_cells_, 2);
    candidates.domain = DomainBox(slab);
    candidates.slab = slab;
    candidates.obstacles = obstacles.obstacles;
    candidates.has_obstacles = !obstacles.obstacles.empty();
    candidates.random = random_placement_;
    candidates.seed = seed_;
    candidates.id_base = id_base_;
    candidates.max_columns = max_columns_;
    candidates.free_stream = free_stream_;
    candidates.specific_energy = specific_energy_;
    candidates.particle_mass = particle_mass_;

    const Kokkos::RangePolicy<ExecutionSpace> policy(0, static_cast<index_t>(num_candidates));
    index_t num_entering = 0;
    Kokkos::parallel_reduce("open_side_count_entering", policy, CountEntering{candidates}, num_entering);
    if (num_entering == 0) continue;
    const index_t first = pt.count;
    pt.grow_to_hold(first + num_entering);
    pt.count = first + num_entering;
    Kokkos::parallel_scan("open_side_append_entering", policy, AppendEntering{candidates, pt, first});
    fluxes_.entered += totals_of_particles(pt, IndexView(), first, num_entering);
  }
}

}  // namespace mpmflow
