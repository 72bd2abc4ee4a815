#pragma once
// The Cartesian Q1 grid as a slab of the global grid: the global node range, the range this rank
// owns and one ghost layer on each side. A single-rank run is the slab that owns everything, so
// the MPI decomposition only has to add communication, never a second code path.
#include "case_config.hpp"
#include "kernels/grid_geometry.hpp"

namespace mpmflow {

struct GridSlab {
  static constexpr int ghost_layers = 1;

  // The global grid.
  index_t global_cells_x = 0;
  index_t global_cells_y = 0;
  real_t domain_x_min = 0, domain_x_max = 0, domain_y_min = 0, domain_y_max = 0;

  // Cells owned by this rank, in global cell indices: [begin, end).
  index_t owned_cell_begin_x = 0, owned_cell_end_x = 0;
  index_t owned_cell_begin_y = 0, owned_cell_end_y = 0;

  // Global index of local node (0, 0); negative on the slab that holds the domain's lower edge.
  index_t node_offset_x = 0;
  index_t node_offset_y = 0;

  GridGeometry geometry;  // local nodes, ghosts included

  real_t cell_size() const {
    return geometry.spacing_x < geometry.spacing_y ? geometry.spacing_x : geometry.spacing_y;
  }
  real_t cell_area() const { return geometry.spacing_x * geometry.spacing_y; }
  // Local index of global node column i / row j (may lie outside the local range).
  index_t local_node_x(index_t global_i) const { return global_i - node_offset_x; }
  index_t local_node_y(index_t global_j) const { return global_j - node_offset_y; }
};

// The slab owning global cells [cell_begin_x, cell_end_x) x all rows.
GridSlab make_grid_slab(const DomainConfig& domain, index_t cell_begin_x, index_t cell_end_x);
// The slab owning global cells [cell_begin, cell_end) along `axis` (0: x, 1: y), all cells across.
GridSlab make_grid_slab(const DomainConfig& domain, int axis, index_t cell_begin, index_t cell_end);

// Node fields of one slab. `state` holds the step's P2G results; `momentum_remap` the second
// momentum P2G (Algorithm 1, step 8), kept apart so the mass column stays intact beside it.
// `per_unit_mass` holds what the G2P kernels interpolate: node momentum and force divided by the
// node mass once per node (on the grid), instead of once per particle and stencil node inside
// the G2P kernels (the paper's theta functor): ppc^2 fewer divisions.
struct GridFields {
  enum StateColumn : int { mass = 0, momentum_x, momentum_y, force_x, force_y, num_state_columns };
  enum RemapColumn : int { remap_momentum_x = 0, remap_momentum_y, num_remap_columns };
  enum PerUnitMassColumn : int {
    velocity_x = 0,    // V-bar: updated momentum / mass (Algorithm 1, step 6)
    velocity_y,
    acceleration_x,    // force / mass (step 7)
    acceleration_y,
    remap_velocity_x,  // remapped momentum / mass (step 10)
    remap_velocity_y,
    num_per_unit_mass_columns
  };

  NodeFieldsView state;
  NodeFieldsView momentum_remap;
  NodeFieldsView per_unit_mass;

  GridFields() = default;
  explicit GridFields(const GridGeometry& geometry)
      : state("node_state", geometry.num_nodes(), num_state_columns),
        momentum_remap("node_momentum_remap", geometry.num_nodes(), num_remap_columns),
        per_unit_mass("node_per_unit_mass", geometry.num_nodes(), num_per_unit_mass_columns) {}

  size_t bytes() const {
    return (state.span() + momentum_remap.span() + per_unit_mass.span()) * sizeof(real_t);
  }
};

}  // namespace mpmflow
