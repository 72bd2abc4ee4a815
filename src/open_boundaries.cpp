#include "open_boundaries.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "counter_random.hpp"
#include "gas_physics.hpp"
#include "kernels/particle_compaction.hpp"

namespace mpmflow {
namespace {

// The inward unit normal of a side.
KOKKOS_INLINE_FUNCTION void inward_normal(int side, real_t& nx, real_t& ny) {
  nx = side == left_side ? 1 : (side == right_side ? -1 : 0);
  ny = side == bottom_side ? 1 : (side == top_side ? -1 : 0);
}

// Whether a point lies outside the domain: it has left through a side that is open (the move
// keeps particles inside at walls and obstacles).
struct OutsideDomain {
  real_t x_min, x_max, y_min, y_max;
  RealView x, y;
  KOKKOS_INLINE_FUNCTION bool operator()(const index_t p) const {
    return x(p) < x_min || x(p) > x_max || y(p) < y_min || y(p) > y_max;
  }
};

// Rows r >= 0 of a lattice column at phase `phase` (in row spacings) that lie within `rows`
// row spacings of the side: those entered once the lattice has moved that far.
KOKKOS_INLINE_FUNCTION long long rows_entered(double rows, double phase) {
  const double x = rows + 1 - phase;  // > 0
  return static_cast<long long>(x);   // floor for x > 0
}

// One step's candidates for entering through one side: (row offset q, column i) for q < max_rows.
struct EntryCandidates {
  EntrySide side;
  Kokkos::View<const double*, DeviceType> distance_before, distance_after, inward_speed;  // per cell, the side's
  real_t x_min, x_max, y_min, y_max;
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
    switch (side.side) {
      case left_side: x = x_min + real_t(depth); y = y_min + real_t(along); break;
      case right_side: x = x_max - real_t(depth); y = y_min + real_t(along); break;
      case bottom_side: x = x_min + real_t(along); y = y_min + real_t(depth); break;
      default: x = x_min + real_t(along); y = y_max - real_t(depth); break;
    }
    x = x < x_min ? x_min : (x > x_max ? x_max : x);
    y = y < y_min ? y_min : (y > y_max ? y_max : y);
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
      pt.position_x(p) = x;
      pt.position_y(p) = y;
      pt.velocity_x(p) = vx;
      pt.velocity_y(p) = vy;
      pt.grid_velocity_x(p) = vx;
      pt.grid_velocity_y(p) = vy;
      pt.mass(p) = candidates.particle_mass;
      pt.density(p) = s.density;
      pt.specific_energy(p) = candidates.specific_energy;
      pt.pressure(p) = s.pressure;
      pt.artificial_viscosity(p) = 0;
      pt.domain_stretch_x(p) = 1;
      pt.domain_stretch_y(p) = 1;
      pt.cell(p) = 0;  // the cell map is recomputed after migration
      pt.id(p) = id;
    }
    ++offset;
  }
};

// The paper's recycling: particle list(k) has left the domain; it re-enters at a random point of a
// random inflow cell, in the strip next to the side that the free stream swept clean during the
// step (depth |v_inf . n| dt, at most one cell), with the free-stream state and particle mass.
// Its random numbers depend on the seed, its id and the step only.
struct Recycle {
  real_t x_min, x_max, y_min, y_max;
  int num_inflow_sides = 0;
  int inflow_side[num_sides] = {};
  real_t inflow_length_end[num_sides] = {};  // cumulative side lengths
  real_t strip_depth[num_sides] = {};
  DeviceObstacleSet obstacles;
  bool has_obstacles = false;
  GasState free_stream;
  real_t specific_energy = 0, particle_mass = 0;
  std::uint64_t seed = 0, step = 0;
  IndexView list;
  ParticleState pt;

  KOKKOS_INLINE_FUNCTION void operator()(const index_t k) const {
    const index_t p = list(k);
    const std::uint64_t id = static_cast<std::uint64_t>(pt.id(p));
    real_t x = x_min, y = y_min;
    constexpr int max_attempts = 16;  // a point inside an obstacle touching the inflow side is drawn again
    for (int attempt = 0; attempt < max_attempts; ++attempt) {
      const real_t along = static_cast<real_t>(counter_uniform(seed, id, step, 2 * attempt)) *
                           inflow_length_end[num_inflow_sides - 1];
      const real_t depth_fraction = static_cast<real_t>(counter_uniform(seed, id, step, 2 * attempt + 1));
      int s = 0;
      while (s < num_inflow_sides - 1 && along >= inflow_length_end[s]) ++s;
      const real_t t = along - (s > 0 ? inflow_length_end[s - 1] : real_t(0));
      const real_t depth = depth_fraction * strip_depth[s];
      switch (inflow_side[s]) {
        case left_side: x = x_min + depth; y = y_min + t; break;
        case right_side: x = x_max - depth; y = y_min + t; break;
        case bottom_side: x = x_min + t; y = y_min + depth; break;
        default: x = x_min + t; y = y_max - depth; break;
      }
      if (!(has_obstacles && obstacles(x, y).distance < 0)) break;
    }
    pt.position_x(p) = x < x_min ? x_min : (x > x_max ? x_max : x);
    pt.position_y(p) = y < y_min ? y_min : (y > y_max ? y_max : y);
    pt.velocity_x(p) = free_stream.velocity_x;
    pt.velocity_y(p) = free_stream.velocity_y;
    pt.grid_velocity_x(p) = free_stream.velocity_x;
    pt.grid_velocity_y(p) = free_stream.velocity_y;
    pt.density(p) = free_stream.density;
    pt.pressure(p) = free_stream.pressure;
    pt.specific_energy(p) = specific_energy;
    pt.mass(p) = particle_mass;
    pt.artificial_viscosity(p) = 0;
    pt.domain_stretch_x(p) = 1;
    pt.domain_stretch_y(p) = 1;
  }
};

// The inward normal speed of the gas at each cell along a far-field side that this rank owns
// (the mean of V-bar on the cell's two side nodes), 0 at the cells of other ranks.
Kokkos::View<double*, Kokkos::HostSpace> far_field_inward_speed(const EntrySide& side, const SlabState& slab_state) {
  const GridSlab& slab = slab_state.slab();
  const GridGeometry geo = slab.geometry;
  const NodeFieldsView velocity = slab_state.fields().per_unit_mass;
  Kokkos::View<double*, DeviceType> speed("far_field_inward_speed", side.cells);
  const int s = side.side;
  const bool along_x = s == bottom_side || s == top_side;
  // The side's global cell and node line across it, and this slab's cells along it.
  const index_t cell_across = (s == left_side || s == bottom_side) ? 0 : slab.global_cells(along_x ? 1 : 0) - 1;
  const index_t node_across = (s == left_side || s == bottom_side) ? 0 : slab.global_cells(along_x ? 1 : 0);
  const IndexRange2D owned = slab.index_space(Ownership::owned, Entity::cell, Indexing::global);
  const int across_axis = along_x ? 1 : 0;
  if (cell_across < owned.begin(across_axis) || cell_across >= owned.end(across_axis))
    return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), speed);
  const index_t first = owned.begin(along_x ? 0 : 1), last = owned.end(along_x ? 0 : 1);
  const index_t offset_x = slab.node_offset_x, offset_y = slab.node_offset_y;
  real_t nx, ny;
  inward_normal(s, nx, ny);
  Kokkos::parallel_for(
      "far_field_inward_speed", Kokkos::RangePolicy<ExecutionSpace>(first, last), KOKKOS_LAMBDA(const index_t c) {
        double sum = 0;
        for (index_t end = 0; end < 2; ++end) {
          const index_t gi = along_x ? c + end : node_across, gj = along_x ? node_across : c + end;
          const index_t node = geo.node_index(gi - offset_x, gj - offset_y);
          sum += velocity(node, GridFields::velocity_x) * nx + velocity(node, GridFields::velocity_y) * ny;
        }
        speed(c) = sum > 0 ? sum / 2 : 0.0;
      });
  return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), speed);
}

}  // namespace

ConservationTotals totals_of_particles(const ParticleState& pt, const IndexView& list, index_t first, index_t count) {
  ConservationTotals totals;
  if (count == 0) return totals;
  const bool listed = list.extent(0) > 0;
  const RealView m = pt.mass, vx = pt.velocity_x, vy = pt.velocity_y, e = pt.specific_energy;
  double* targets[] = {&totals.mass, &totals.momentum_x, &totals.momentum_y, &totals.kinetic_energy,
                       &totals.internal_energy};
  for (int which = 0; which < 5; ++which) {
    double sum = 0;
    Kokkos::parallel_reduce(
        "open_side_totals", Kokkos::RangePolicy<ExecutionSpace>(0, count),
        KOKKOS_LAMBDA(const index_t k, double& total) {
          const index_t p = listed ? list(k) : first + k;
          const double mass = m(p);
          switch (which) {
            case 0: total += mass; break;
            case 1: total += mass * vx(p); break;
            case 2: total += mass * vy(p); break;
            case 3: total += 0.5 * mass * (double(vx(p)) * vx(p) + double(vy(p)) * vy(p)); break;
            default: total += mass * e(p); break;
          }
        },
        sum);
    *targets[which] = sum;
  }
  return totals;
}

OpenBoundaries::OpenBoundaries(const CaseConfig& config) : config_(config) {
  const DomainConfig& d = config.domain;
  const double hx = (double(d.x_max) - d.x_min) / d.cells_x, hy = (double(d.y_max) - d.y_min) / d.cells_y;
  const BoundaryType types[num_sides] = {config.boundaries.left, config.boundaries.right, config.boundaries.bottom,
                                         config.boundaries.top};
  if (config.boundaries.particle_supply != ParticleSupply::open) return;
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
    real_t nx, ny;
    inward_normal(s, nx, ny);
    side.free_stream_inward =
        double(config.boundaries.free_stream.velocity_x) * nx + double(config.boundaries.free_stream.velocity_y) * ny;
    sides_.push_back(side);
    first_cell += side.cells;
  }
  entry_distance_.assign(static_cast<size_t>(first_cell), 0.0);
}

void OpenBoundaries::restore(const std::vector<double>& entry_distance, const BoundaryFluxes& fluxes) {
  entry_distance_ = entry_distance;
  fluxes_ = fluxes;
}

void OpenBoundaries::exchange(ParticleState& pt, const SlabState& slab_state, real_t dt, long step) {
  const CaseConfig& config = config_;
  if (!config.boundaries.any_open()) return;
  const GridSlab& slab = slab_state.slab();
  const real_t x_min = slab.domain_x_min, x_max = slab.domain_x_max, y_min = slab.domain_y_min,
               y_max = slab.domain_y_max;
  const GasState& free_stream = config.boundaries.free_stream;
  const real_t specific_energy = perfect_gas_specific_energy(config.physics.gamma, free_stream.density,
                                                             free_stream.pressure);
  const index_t per_cell = config.particles.per_cell_x * config.particles.per_cell_y;
  // As create_initial_particles computes it, so that entering and initial particles weigh the same.
  const real_t particle_mass = free_stream.density * (slab.cell_area() / per_cell);
  const ObstacleGrid& obstacles = slab_state.obstacles();

  // The particles that have left.
  const OutsideDomain outside{x_min, x_max, y_min, y_max, pt.position_x, pt.position_y};
  const IndexView leaving = select_indices("open_side_leaving", 0, pt.count, outside);
  const index_t num_leaving = static_cast<index_t>(leaving.extent(0));
  const ConservationTotals left = totals_of_particles(pt, leaving, 0, num_leaving);
  fluxes_.left += left;

  if (config.boundaries.particle_supply == ParticleSupply::recycle) {
    if (num_leaving == 0) return;
    Recycle recycle;
    recycle.x_min = x_min, recycle.x_max = x_max, recycle.y_min = y_min, recycle.y_max = y_max;
    const BoundaryType types[num_sides] = {config.boundaries.left, config.boundaries.right,
                                           config.boundaries.bottom, config.boundaries.top};
    real_t length = 0;
    for (int s = 0; s < num_sides; ++s) {
      if (types[s] != BoundaryType::inflow) continue;
      const bool x_normal = s == left_side || s == right_side;
      length += x_normal ? (y_max - y_min) : (x_max - x_min);
      real_t nx, ny;
      inward_normal(s, nx, ny);
      const real_t cell_depth = x_normal ? slab.geometry.spacing_x : slab.geometry.spacing_y;
      const real_t swept = (free_stream.velocity_x * nx + free_stream.velocity_y * ny) * dt;
      recycle.inflow_side[recycle.num_inflow_sides] = s;
      recycle.inflow_length_end[recycle.num_inflow_sides] = length;
      recycle.strip_depth[recycle.num_inflow_sides] = swept > 0 ? std::min(swept, cell_depth) : cell_depth;
      ++recycle.num_inflow_sides;
    }
    recycle.obstacles = obstacles.obstacles;
    recycle.has_obstacles = !obstacles.obstacles.empty();
    recycle.free_stream = free_stream;
    recycle.specific_energy = specific_energy;
    recycle.particle_mass = particle_mass;
    recycle.seed = config.particles.seed;
    recycle.step = static_cast<std::uint64_t>(step);
    recycle.list = leaving;
    recycle.pt = pt;
    Kokkos::parallel_for("recycle", Kokkos::RangePolicy<ExecutionSpace>(0, num_leaving), recycle);
    fluxes_.entered += totals_of_particles(pt, leaving, 0, num_leaving);
    return;
  }

  // Open: the particles that have left are removed ...
  if (num_leaving > 0) {
    const HoleFilling plan = plan_hole_filling(pt.count, leaving, outside);
    pt.for_each_field([&](const auto& field) { fill_holes(field, plan.holes, plan.fillers, plan.count); });
    pt.count = plan.staying;
  }

  // ... and the lattice outside the entering sides moves in by its inward speed x dt.
  for (const EntrySide& side : sides_) {
    std::vector<double> speed(static_cast<size_t>(side.cells), side.free_stream_inward > 0 ? side.free_stream_inward : 0);
    if (side.far_field) {
      const auto local = far_field_inward_speed(side, slab_state);
      for (index_t c = 0; c < side.cells; ++c) speed[c] = local(c);
      slab_state.context().sum_in_place(speed.data(), static_cast<int>(speed.size()));
    }
    Kokkos::View<double*, Kokkos::HostSpace> before("entry_distance_before", side.cells),
        after("entry_distance_after", side.cells), speed_host("entry_speed", side.cells);
    double largest_advance = 0;
    for (index_t c = 0; c < side.cells; ++c) {
      double& distance = entry_distance_[side.first_cell + c];
      before(c) = distance;
      distance += speed[c] * dt;
      after(c) = distance;
      speed_host(c) = speed[c];
      largest_advance = std::max(largest_advance, after(c) - before(c));
    }
    if (largest_advance <= 0) continue;
    // Rows entering a column in one step: at most the advance in row spacings, rounded up, + 1.
    const long long max_rows = static_cast<long long>(largest_advance / side.row_spacing) + 2;
    const long long num_candidates = max_rows * side.columns;
    if (num_candidates > static_cast<long long>(std::numeric_limits<index_t>::max()))
      throw std::runtime_error("open boundaries: the step of " + std::to_string(dt) +
                               " moves the free stream over too many particle rows at once");

    EntryCandidates candidates;
    candidates.side = side;
    candidates.distance_before = Kokkos::create_mirror_view_and_copy(MemorySpace(), before);
    candidates.distance_after = Kokkos::create_mirror_view_and_copy(MemorySpace(), after);
    candidates.inward_speed = Kokkos::create_mirror_view_and_copy(MemorySpace(), speed_host);
    candidates.x_min = x_min, candidates.x_max = x_max, candidates.y_min = y_min, candidates.y_max = y_max;
    candidates.slab = slab;
    candidates.obstacles = obstacles.obstacles;
    candidates.has_obstacles = !obstacles.obstacles.empty();
    candidates.random = config.particles.placement == ParticlePlacement::random;
    candidates.seed = config.particles.seed;
    candidates.id_base = static_cast<particle_id_t>(slab.global_cells_x) * slab.global_cells_y * per_cell;
    candidates.max_columns = std::max<particle_id_t>(
        static_cast<particle_id_t>(slab.global_cells_x) * config.particles.per_cell_x,
        static_cast<particle_id_t>(slab.global_cells_y) * config.particles.per_cell_y);
    candidates.free_stream = free_stream;
    candidates.specific_energy = specific_energy;
    candidates.particle_mass = particle_mass;

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
