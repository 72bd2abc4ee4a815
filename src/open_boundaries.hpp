#pragma once
// The open sides of the domain (inflow, outflow, far field) and the particles that cross them,
// after the move (Algorithm 1, step 11), in one of two ways (boundaries/particle_supply):
//
// - `open` (the default): a particle that has left the domain through an open side is removed;
//   free-stream particles enter through inflow and far-field sides. The particle count varies.
// - `recycle` (the paper's): a particle that has left is put back into the inflow strip the free
//   stream swept clean during the step, where it left along its side and as deep as it went beyond
//   it (Recycle), with the free-stream state. The count is fixed, so the mass a body's shock layer
//   stores is taken from the free stream ahead of it.
//
// Entering particles. Outside each entering side lies a lattice of free-stream particles, the
// continuation of the case's particles per cell: `columns` = cells along the side x particles per
// cell along it, each column `row_spacing` = cell depth / particles per cell across it between
// rows, each particle the case's free-stream particle mass. The lattice moves towards the side at
// the inward normal speed: the free stream's on an inflow side; on a far-field side, in each cell
// along it, that of the gas at the side (the grid velocity V-bar of the step on its two side
// nodes) where it points inwards, and nothing where it points outwards; on a far-field side the
// free stream does not enter (one it runs along, or an outlet), where the gas does not point
// outwards, the lattice moves in further if that does not fill the strip one cell deep along the
// side: by the strip's area covered neither by its particles' volumes m / rho (each by the share
// of its extent across the side, a row spacing, that lies within the strip) nor by the lattice's
// next rows (each column's reaches half a row spacing past its centre), per unit width (the free
// stream outside fills the gaps the particles leave at the side; the volumes are summed in
// integer units, so that the sum, and what enters, does not depend on the particle order, the
// threads or the ranks). entry_distance(cell) accumulates how far the lattice has moved. Row r of column i lies (r + phase_i) row spacings
// outside, phase_i = (i + 1/2) / columns, and enters once entry_distance passes it: placed that
// far inside (regular placement), or jittered uniformly within its own row spacing and column
// width, reflected at the side (random placement), with the free-stream density, pressure and
// internal energy, and the free-stream velocity (on a far-field side: the free stream's
// tangential velocity and the gas's inward normal speed). The phases are those of Hermite's
// identity, sum_i floor(x + i / N) = floor(N x): on a side with one inward speed, the particles
// entered up to any step number round(columns x entry_distance / row_spacing), so the mass entered
// in every step is rho_inf (v_inf . n) x side length x dt to within one particle's mass.
//
// Ids and random numbers. A particle entering row r of column i of side s gets the id
//   cells_x cells_y ppc + (r num_sides + s) max_columns + i,
// above every initial id and never reused; its random numbers are a function of the seed and that
// id. Both are independent of the step size, the threads, the ranks and the particle order; each
// rank creates the entering particles whose cells it owns, in (side, row, column) order.
#include <cstdint>
#include <string>
#include <vector>

#include "boundary_conditions.hpp"
#include "case_config.hpp"
#include "counter_random.hpp"
#include "diagnostics.hpp"
#include "particles.hpp"
#include "slab_state.hpp"

#include "kernels/kept_scatter_view.hpp"

namespace mpmflow {

// A side through which particles enter, as the kernels see it.
struct EntrySide {
  int side = 0;
  bool far_field = false;
  index_t cells = 0;            // cells along the side
  index_t first_cell = 0;       // offset of its cells in the entry-distance arrays
  index_t columns = 0;          // cells x particles per cell along the side
  int per_cell_along = 1;       // particles per cell along the side
  double row_spacing = 0;       // cell depth / particles per cell across the side
  double column_width = 0;      // cell width along the side / particles per cell along it
  double free_stream_inward = 0;  // v_inf . (inward normal)
  bool fills_strip = false;  // a far-field side but an inlet (far_field_inlet): the strip fill acts
};

// Gives particle p of `pt` the free-stream state `s` (its specific energy and particle mass too)
// at (x, y), in its cell of `grid`, with velocity (vx, vy): what a particle entering at an open side
// starts with, whether newly created or recycled.
KOKKOS_INLINE_FUNCTION void set_free_stream_particle(const ParticleState& pt, index_t p, const GridGeometry& grid,
                                                     real_t x, real_t y, real_t vx, real_t vy, const GasState& s,
                                                     real_t specific_energy, real_t particle_mass) {
  pt.position_x(p) = x;
  pt.position_y(p) = y;
  pt.cell(p) = grid.cell_of(x, y);
  pt.velocity_x(p) = vx;
  pt.velocity_y(p) = vy;
  pt.mass(p) = particle_mass;
  pt.density(p) = s.density;
  pt.specific_energy(p) = specific_energy;
  pt.artificial_viscosity(p) = 0;
  pt.domain_stretch_x(p) = 1;
  pt.domain_stretch_y(p) = 1;
}

// The paper's recycling, for particles that have left the domain: each re-enters in the strip
// next to an inflow side that the free stream swept clean during the step (depth |v_inf . n| dt, at
// most one cell), with the free-stream state and its own mass: at the same fraction of the inflow
// sides' length as of the side it left along, and as far inside the strip as it went beyond that
// side. (In a tunnel, inflow left and outflow right, a particle leaving at height y re-enters at
// height y: the spacing the gas leaves with is the spacing it re-enters with, which for a free
// stream is the placement's. The paper draws a random point, and the gas re-enters clumped: a
// free stream's density scattered by 12 % by t = 3, 9 particles per cell, regular or random.)
// Where that point lies in an obstacle, random points are drawn, from the seed, its id and the
// step only.
struct Recycle {
  DomainBox domain;
  int num_inflow_sides = 0;
  int inflow_side[num_sides] = {};
  real_t inflow_length_end[num_sides] = {};  // cumulative side lengths
  real_t inward_speed[num_sides] = {};       // v_inf . (inward normal)
  real_t cell_depth[num_sides] = {};
  DeviceObstacleSet obstacles;
  bool has_obstacles = false;
  GasState free_stream;
  real_t specific_energy = 0;
  std::uint64_t seed = 0;
  // Of the step:
  real_t strip_depth[num_sides] = {};
  std::uint64_t step = 0;
  GridGeometry grid;  // for the particles' cells
  IndexView list;  // the particles that have left
  ParticleState pt;

  KOKKOS_INLINE_FUNCTION void operator()(index_t k) const;
};

class OpenBoundaries {
 public:
  OpenBoundaries() = default;
  // For `config`, on any slab of its grid (the slab gives the cell size).
  OpenBoundaries(const CaseConfig& config, const GridSlab& slab);

  // The cells along the entering sides: the length of entry_distance().
  static size_t num_entry_cells(const CaseConfig& config);

  // After the move: the particles outside the domain are removed (or recycled), and those that
  // the lattice outside the entering sides brought in during the step of size dt are created on
  // this rank where it owns their cells. `step` numbers the step (recycling's random numbers).
  // Collective when a side is a far field (the inward speeds along it are summed over the ranks).
  void exchange(ParticleState& particles, const SlabState& slab, real_t dt, long step);

  // This rank's fluxes since the start of the run (or of the restart; see restore).
  const BoundaryFluxes& fluxes() const { return fluxes_; }
  // Adds a step's energy terms of the boundaries (BoundaryFluxes) on this rank.
  void add_boundary_energy(double boundary_work, double kinetic_energy_stopped) {
    fluxes_.boundary_work += boundary_work;
    fluxes_.kinetic_energy_stopped += kinetic_energy_stopped;
  }
  // How far the lattice outside each entering side has moved, per cell along it (the sides in
  // the order left, right, bottom, top): the same on every rank.
  const std::vector<double>& entry_distance() const { return entry_distance_; }
  // A restart: the entry distances and this rank's share of the fluxes.
  void restore(const std::vector<double>& entry_distance, const BoundaryFluxes& fluxes);

 private:
  void recycle(ParticleState& particles, const SlabState& slab, const IndexView& leaving, real_t dt, long step);
  void enter(ParticleState& particles, const SlabState& slab, real_t dt);

  ParticleSupply supply_ = ParticleSupply::open;
  bool any_open_ = false;
  bool random_placement_ = false;
  std::uint64_t seed_ = 0;
  GasState free_stream_;
  real_t specific_energy_ = 0;  // of the free stream
  real_t particle_mass_ = 0;    // of a free-stream particle, as create_initial_particles computes it
  particle_id_t id_base_ = 0;   // above every initial id
  particle_id_t max_columns_ = 0;
  Recycle recycle_;  // its fields fixed for the run
  std::vector<EntrySide> sides_;
  std::vector<double> entry_distance_;
  // Per entry cell, for one step's kernels (allocated once, with their host copies): the entry
  // distance before and after the step and the inward speed, in a block of the three a side
  // (enter: one copy a side to the device); the far-field strips' volumes.
  Kokkos::View<double*, DeviceType> entry_cells_;
  Kokkos::View<double*, DeviceType>::HostMirror entry_cells_host_;
  Kokkos::View<long long*, DeviceType> strip_volume_;  // per entry cell: its far-field strip's volume
  Kokkos::View<long long*, DeviceType>::HostMirror strip_volume_host_;
  KeptScatterView<long long> strip_volume_scatter_;  // the additions into strip_volume_
  BoundaryFluxes fluxes_;
  IndexView leaving_;  // the list of the particles that left (select_indices), kept from step to step
  IndexView fillers_;  // the staying particles that fill their places (plan_hole_filling), kept likewise
};

// The conservation totals of `count` particles: those listed in `list`, or, with an empty
// list, those from index `first` on.
ConservationTotals totals_of_particles(const ParticleState& particles, const IndexView& list, index_t first,
                                       index_t count);

// ---- inline definitions --------------------------------------------------------------------------

KOKKOS_INLINE_FUNCTION void Recycle::operator()(const index_t k) const {
  const index_t p = list(k);
  const std::uint64_t id = static_cast<std::uint64_t>(pt.id(p));
  // Where it left: the side it crossed furthest, how far along that side (from its corner at x_min
  // or y_min, as a fraction of the side) and how far beyond it.
  const real_t px = pt.position_x(p), py = pt.position_y(p);
  const real_t beyond_x = px > domain.x_max ? px - domain.x_max : (px < domain.x_min ? domain.x_min - px : real_t(0));
  const real_t beyond_y = py > domain.y_max ? py - domain.y_max : (py < domain.y_min ? domain.y_min - py : real_t(0));
  const bool across_x = beyond_x >= beyond_y;
  const real_t beyond = across_x ? beyond_x : beyond_y;
  real_t along_fraction = across_x ? (py - domain.y_min) / (domain.y_max - domain.y_min)
                                   : (px - domain.x_min) / (domain.x_max - domain.x_min);
  along_fraction = along_fraction < 0 ? real_t(0) : (along_fraction > 1 ? real_t(1) : along_fraction);
  const real_t inflow_length = inflow_length_end[num_inflow_sides - 1];
  real_t x = domain.x_min, y = domain.y_min;
  constexpr int max_attempts = 16;  // a point inside an obstacle touching the inflow side is drawn again
  for (int attempt = 0; attempt < max_attempts; ++attempt) {
    // First the same place along the inflow and as far inside as it went beyond; then random points.
    const bool where_it_left = attempt == 0;
    const real_t along = where_it_left ? along_fraction * inflow_length
                                       : static_cast<real_t>(counter_uniform(seed, id, step, 2 * attempt)) *
                                             inflow_length;
    int s = 0;
    while (s < num_inflow_sides - 1 && along >= inflow_length_end[s]) ++s;
    const real_t t = along - (s > 0 ? inflow_length_end[s - 1] : real_t(0));
    // Beyond by more than the strip is deep (the gas left faster than the free stream enters):
    // wrapped into it, so that the depths stay spread over it.
    const real_t depth = where_it_left ? beyond - strip_depth[s] * GridGeometry::floor_div(beyond, strip_depth[s])
                                       : static_cast<real_t>(counter_uniform(seed, id, step, 2 * attempt + 1)) *
                                             strip_depth[s];
    domain.point_inside_side(inflow_side[s], t, depth, x, y);
    if (!(has_obstacles && obstacles(x, y).distance < 0)) break;
  }
  // Its own mass: a split particle re-entering with a whole free-stream particle's mass would make
  // mass (the bundled cylinder held 48 % more by t = 3).
  set_free_stream_particle(pt, p, grid, x, y, free_stream.velocity_x, free_stream.velocity_y, free_stream,
                           specific_energy, pt.mass(p));
}

}  // namespace mpmflow
