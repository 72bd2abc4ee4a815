#pragma once
// The Cartesian Q1 grid as a slab of the global grid: the global node range, the range this rank
// owns and one ghost layer on each side. A single-rank run is the slab that owns everything, so
// the MPI decomposition only has to add communication, never a second code path.
//
// Every index range of a slab comes from its queries (after Cabana's LocalGrid::indexSpace):
// owned and ghosted nodes and cells, in local or global indices; the node lines shared with a
// neighbouring slab; the node lines on and beyond a side of the domain. The boundary conditions,
// the halo exchange, the output, particle migration and load balancing all ask the slab.
#include "case_config.hpp"
#include "kernels/grid_geometry.hpp"

namespace mpmflow {

// The sides of the domain.
enum Side : int { left_side = 0, right_side, bottom_side, top_side, num_sides };

// The inward unit normal of a side.
KOKKOS_INLINE_FUNCTION void inward_normal(int side, real_t& nx, real_t& ny) {
  nx = side == left_side ? 1 : (side == right_side ? -1 : 0);
  ny = side == bottom_side ? 1 : (side == top_side ? -1 : 0);
}

// Index rectangle [begin_x, end_x) x [begin_y, end_y) of nodes or cells (also in device code: the
// halo exchange's and the side conditions' kernels walk such rectangles).
struct IndexRange2D {
  index_t begin_x = 0, end_x = 0;
  index_t begin_y = 0, end_y = 0;

  KOKKOS_INLINE_FUNCTION index_t extent_x() const { return end_x > begin_x ? end_x - begin_x : 0; }
  KOKKOS_INLINE_FUNCTION index_t extent_y() const { return end_y > begin_y ? end_y - begin_y : 0; }
  KOKKOS_INLINE_FUNCTION index_t size() const { return extent_x() * extent_y(); }
  KOKKOS_INLINE_FUNCTION bool empty() const { return size() == 0; }
  KOKKOS_INLINE_FUNCTION bool contains(index_t i, index_t j) const {
    return i >= begin_x && i < end_x && j >= begin_y && j < end_y;
  }
  // The indices (i, j) of the rectangle's k-th entry, numbered row by row from (begin_x, begin_y):
  // k = (i - begin_x) + extent_x() (j - begin_y), for k in [0, size()).
  KOKKOS_INLINE_FUNCTION index_t i_of(index_t k) const { return begin_x + k % extent_x(); }
  KOKKOS_INLINE_FUNCTION index_t j_of(index_t k) const { return begin_y + k / extent_x(); }
  index_t begin(int axis) const { return axis == 0 ? begin_x : begin_y; }
  index_t end(int axis) const { return axis == 0 ? end_x : end_y; }
  bool operator==(const IndexRange2D& o) const {
    return begin_x == o.begin_x && end_x == o.end_x && begin_y == o.begin_y && end_y == o.end_y;
  }
};

// Which part of the slab an index query asks for.
enum class Ownership {
  owned,    // what this slab answers for: its cells; its nodes, each node of the domain on one slab
  ghosted,  // everything held locally, ghost layers included
};
enum class Entity { node, cell };
enum class Indexing { local, global };

struct GridSlab {
  static constexpr int ghost_layers = 1;
  // Node lines a slab shares with each neighbour: those around their common face.
  static constexpr int shared_lines = 2 * ghost_layers + 1;

  // The global grid.
  index_t global_cells_x = 0;
  index_t global_cells_y = 0;
  real_t domain_x_min = 0, domain_x_max = 0, domain_y_min = 0, domain_y_max = 0;
  // The axis the domain is cut along into slabs (0: x, 1: y).
  int axis = 0;

  // Cells owned by this rank, in global cell indices: [begin, end).
  index_t owned_cell_begin_x = 0, owned_cell_end_x = 0;
  index_t owned_cell_begin_y = 0, owned_cell_end_y = 0;

  // Global index of local node (0, 0); negative on the slab that holds the domain's lower edge.
  // Local cell (i, j) has local node (i, j) as its lower-left corner, so cells share the offset.
  index_t node_offset_x = 0;
  index_t node_offset_y = 0;

  GridGeometry geometry;  // local nodes, ghosts included

  real_t cell_size() const {
    return geometry.spacing_x < geometry.spacing_y ? geometry.spacing_x : geometry.spacing_y;
  }
  real_t cell_area() const { return geometry.spacing_x * geometry.spacing_y; }
  KOKKOS_INLINE_FUNCTION index_t global_cells(int along) const { return along == 0 ? global_cells_x : global_cells_y; }
  KOKKOS_INLINE_FUNCTION index_t node_offset(int along) const { return along == 0 ? node_offset_x : node_offset_y; }
  // Local index of global node column i / row j (may lie outside the local range), and back.
  index_t local_node_x(index_t global_i) const { return global_i - node_offset_x; }
  index_t local_node_y(index_t global_j) const { return global_j - node_offset_y; }

  // The nodes or cells of `ownership`, in local or global indices.
  IndexRange2D index_space(Ownership ownership, Entity entity, Indexing indexing) const;
  // The node lines shared with the neighbouring slab below (direction -1) or above (+1) along
  // `axis`, in local indices; empty where this slab reaches the domain's edge (no neighbour).
  IndexRange2D shared_node_space(int direction) const;
  // The local nodes of the global node line `layer` lines outside `side` (0: the side itself),
  // all along it, ghosts included; empty where the slab does not hold that line.
  IndexRange2D boundary_node_line(Side side, int layer) const;
  // The nodes of the domain (global nodes 0 .. cells on each axis) held locally, in local indices.
  IndexRange2D domain_node_space() const;
  // The owned nodes and, where the slab reaches a side of the domain, the ghost nodes beyond it
  // (which GIMP stencils reach), in local indices: every node a particle touches, each on one slab.
  IndexRange2D owned_nodes_with_outer_ghosts() const;

  // Global cell index along `along` of the point (x, y) (it may lie outside this slab),
  // clamped to the domain: the arithmetic of GridGeometry::cell_of on the global grid.
  KOKKOS_INLINE_FUNCTION index_t global_cell_along(int along, real_t x, real_t y) const {
    return global_cell_at(along, along == 0 ? x : y);
  }
  // The same from the point's coordinate along `along` alone (so that a pass needing nothing else
  // reads only that one).
  KOKKOS_INLINE_FUNCTION index_t global_cell_at(int along, real_t coordinate) const {
    const index_t cell = geometry.cell_along(along, coordinate, geometry.inverse_spacing(along)) + node_offset(along);
    return cell < 0 ? 0 : (cell >= global_cells(along) ? global_cells(along) - 1 : cell);
  }
};

// The slab owning global cells [cell_begin, cell_end) along `axis` (0: x, 1: y), all cells across.
GridSlab make_grid_slab(const DomainConfig& domain, int axis, index_t cell_begin, index_t cell_end);
// The slab owning global cells [cell_begin_x, cell_end_x) x all rows.
inline GridSlab make_grid_slab(const DomainConfig& domain, index_t cell_begin_x, index_t cell_end_x) {
  return make_grid_slab(domain, 0, cell_begin_x, cell_end_x);
}

// Node fields of one slab. `state` holds the step's P2G results. Its momentum columns hold mv
// (step 3), then (mv)' (step 5), then, as Algorithm 1 writes it, the remapped momentum mv =
// P2G(M V') (step 8): (mv)' lives on as V-bar in `per_unit_mass`, and the remap needs no View, nor
// ScatterView copies, of its own.
// `per_unit_mass` holds what the G2P kernels interpolate: node momentum and force divided by the
// node mass once per node (on the grid), instead of once per particle and stencil node inside
// the G2P kernels (the paper's theta functor): ppc^2 fewer divisions.
struct GridFields {
  // pressure_volume: sum_p phi_i P M / rho, with the mass the nodes' sound speed for the time step.
  // volume: sum_p phi_i M / rho, the particles' volume on the node (numerics/volume_correction).
  enum StateColumn : int {
    mass = 0,
    momentum_x,
    momentum_y,
    pressure_volume,
    volume,
    force_x,
    force_y,
    num_state_columns
  };
  // (In the order the kernels read them: the acceleration alone by G2P, V-bar, the remapped
  // velocity, the volume fraction and the mean pressure together by the G2P-and-G2PD of steps
  // 10-11.)
  enum PerUnitMassColumn : int {
    acceleration_x = 0,  // force / mass (step 7)
    acceleration_y,
    velocity_x,          // V-bar: updated momentum / mass (Algorithm 1, step 6), which moves the particles
    velocity_y,
    remap_velocity_x,    // remapped momentum / mass (step 10)
    remap_velocity_y,
    volume_fraction,     // volume over the gas volume the node's hat covers (numerics/volume_correction)
    mean_pressure,       // sum_p phi_i P V / sum_p phi_i V (the volume correction; not per unit mass, but
                         // read with the rest)
    num_per_unit_mass_columns
  };
  // The columns of the projection of the particles' state for grid output: mass and momentum
  // (the first three of `state`), and mass times density, pressure and specific internal energy
  // (divided by the mass: their mass-weighted averages on the node).
  enum ProjectionColumn : int {
    projected_mass = 0,
    projected_momentum_x,
    projected_momentum_y,
    projected_mass_density,
    projected_mass_pressure,
    projected_mass_energy,
    num_projection_columns
  };

  // Momentum and force (step 3) and remapped momentum (step 8) as the particles gave them, before
  // the boundary conditions, on the nodes those may change (conditioned_node(k), this slab's
  // share: GridBoundaryConditions::conditioned_nodes), row k: for the work the conditions do
  // (energy budget). Elsewhere they change nothing, and their work there is none.
  enum BeforeConditionsColumn : int {
    raw_momentum_x = 0,
    raw_momentum_y,
    raw_force_x,
    raw_force_y,
    raw_remap_momentum_x,
    raw_remap_momentum_y,
    num_before_conditions_columns
  };

  NodeFieldsView state;
  NodeFieldsView per_unit_mass;
  IndexView conditioned_node;
  NodeFieldsView before_conditions;

  GridFields() = default;
  explicit GridFields(const GridGeometry& geometry)
      : state("node_state", geometry.num_nodes(), num_state_columns),
        per_unit_mass("node_per_unit_mass", geometry.num_nodes(), num_per_unit_mass_columns) {}

  // The nodes the boundary conditions may change, and room for their columns before them.
  void set_conditioned_nodes(const IndexView& nodes) {
    conditioned_node = nodes;
    before_conditions = NodeFieldsView("node_before_conditions", nodes.extent(0), num_before_conditions_columns);
  }

  size_t bytes() const {
    return (state.span() + per_unit_mass.span() + before_conditions.span()) * sizeof(real_t) +
           conditioned_node.span() * sizeof(index_t);
  }
};

}  // namespace mpmflow
