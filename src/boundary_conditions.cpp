#include "boundary_conditions.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "gas_physics.hpp"
#include "kernels/index_lanes.hpp"
#include "kernels/reductions.hpp"
#include "kernels/shape_functions.hpp"

namespace mpmflow {
namespace {

// Whether gas outside the side presses on it: outflow and far field.
bool pressure_side(BoundaryType type) { return type == BoundaryType::outflow || type == BoundaryType::far_field; }

// The node lines a side's condition visits (some may be empty on this slab): the side's line and
// the ghost lines beyond it, which GIMP stencils reach, all along the side. The one list that the
// conditions and the energy budget's nodes (GridBoundaryConditions::conditioned_nodes) share.
// A pressure side's take in the line inside too (PressureSideNodes).
std::vector<IndexRange2D> condition_lines(const GridSlab& slab, BoundaryType type, Side side) {
  std::vector<IndexRange2D> lines;
  const int first_layer = pressure_side(type) ? -PressureSideNodes::inner_layers : 0;
  for (int layer = first_layer; layer <= GridSlab::ghost_layers; ++layer)
    lines.push_back(slab.boundary_node_line(side, layer));
  return lines;
}

// A side's condition lines as one rectangle: they are the side's line and the lines beyond it, next
// to each other (those on this slab), so that a condition visits them in one launch.
IndexRange2D condition_band(const GridSlab& slab, BoundaryType type, Side side) {
  IndexRange2D band;
  for (const IndexRange2D& line : condition_lines(slab, type, side)) {
    if (line.empty()) continue;
    if (band.empty()) {
      band = line;
      continue;
    }
    band = {std::min(band.begin_x, line.begin_x), std::max(band.end_x, line.end_x),
            std::min(band.begin_y, line.begin_y), std::max(band.end_y, line.end_y)};
  }
  return band;
}

// The gas outside on the outflow and far-field sides, as it acts on the nodes there: the force on
// node (i, j) (a struct rather than a private member: CUDA forbids device lambdas in private
// members).
//
// The gas outside is a continuum at the free-stream state. Where the free stream crosses the side
// (PressureSideNodes::crossed) and gas crosses it there or may fall short of it (at every node of
// an outflow side; at a far-field outlet where the gas at the side's node moves out; at every node
// of a far-field inlet, where the entering lattice moves in with the gas), the particles reach past
// the side and fall short of it; the gas outside fills what they leave uncovered. Its stress
// contributes
//   f_i = -\int_outside sigma grad N_i dA = p_out \int_outside grad N_i dA = -p_out g_i,
// g_i = \int_particles grad N_i dA = sum_p (M / rho) grad phi_i (GIMP's weights are averages over
// the particle's domain; the shape functions vanish far off), to the nodes whose shape functions
// reach the uncovered part: the side's line, the line inside it and the ghost line beyond. Their
// force is then sum_p (P + Q - p_out) (M / rho) grad phi_i: nothing for gas at the outside
// pressure, wherever the last particles end. (With the traction below there, the ghost nodes felt
// the particles reaching past the side unopposed, and the line inside those falling short: a
// uniform stream at Mach 0.42 leaving through the side drew a rarefaction from it and lost 3.4 % of
// its mass by t = 2; one entering through a far-field side slowed from 0.5 to 0.22 by t = 3:
// README, Wind tunnel.)
// Where the particles end at the side, this is the traction below. On an outflow side the gas moves
// away from the side wherever the gas outside presses harder than the gas inside, and the particles
// fall short of it: with the traction there (until 2026-12-06) the side's nodes kept the whole
// outside pressure while the particles on them thinned out, and crushed the last particles (a
// channel at rest at pressure 1 with gas outside at 1.5, WindTunnel.TheGasOutsideAnOutflowSide...:
// 5.33 on the last particle, 0.70 beside it; now 0.845 to 1.585). The gas outside reaches only the
// three lines: an outflow side lets no gas in, and a far field is the side for gas pushed in.
// Elsewhere (far-field sides the free stream runs along, a far-field outlet's nodes where the gas
// does not move out) the gas outside acts on the side as a traction, f_i -= p_out n \int_side N_i
// ds on the side's nodes. (The gauge on far-field sides along the flow let the particles crowd
// there: with the outside pressure taken out of their forces, particles that overlap no longer push
// apart, and the strip fill, OpenBoundaries, keeps adding where the random arrangement leaves gaps:
// the rows along them 1.52 and 1.55 against 1.4 in
// WindTunnel.FarFieldAlongTheFlowKeepsTheFreeStream.)
// The outside pressure p_out is the free stream's, except on a far-field side the free stream
// enters (an inlet): there that of the Riemann invariants of the flow normal to the side, the
// entering one from the free stream, the leaving one from the gas at the side's node
// (far_field_boundary_pressure, with the node's density m / V, pressure sum P V / V and normal
// velocity), which holds the entering gas's normal velocity. The free-stream pressure alone leaves
// it free: any uniform stream at p_inf is in equilibrium with it, and the diagonal stream of
// WindTunnel.AStreamCrossingFarFieldSidesKeepsItsState, (0.5, 0.3), drifted to (0.468, 0.313) by
// t = 3 with it (everything else as here). Elsewhere the invariants' pressure did worse than the
// free stream's: on sides the free stream runs along it let a random arrangement's gas leak out (a
// Mach 0.42 stream through the same box with an inflow side and far-field sides along the flow,
// random placement, 3 x 3, lost 2.3 % of its mass by t = 3); at outlets it took
// WindTunnel.SubsonicFarFieldLetsGasInAndOut from -0.03 % to -0.7 % of its mass and the channel of
// ASubsonicStreamLeavesThroughItsOutletUndisturbed, with 2 x 2 random particles per cell, from
// +3.8 % to +4.6 %.
// Its mass contributes inertia: the part of a node's dual cell beyond a pressure side (half of a
// side node's, all of a ghost node's) holds gas that moves with the node and takes its share of
// the node's force. The node's acceleration is then f / (m + m_outside); the velocity the particles
// give the node is kept. A side node whose particles have thinned out (gas leaving along a side
// parallel to the flow) thus still feels the gas outside, and is pushed inwards until the gas fills
// the side again, by an acceleration no larger than that of a node holding the gas outside alone.
// (With the traction scaled by the node's share of a full node's mass instead, a thinning side
// lost ever more of it and drained the tunnel; with the traction whole on the particles' mass
// alone, nearly empty nodes threw particles into the domain.)
struct SidePressure {
  // Per axis: whether the domain's low and high sides are pressure sides.
  bool left = false, right = false, bottom = false, top = false;
  Kokkos::Array<bool, num_sides> inflow = {};  // by Side
  Kokkos::Array<real_t, num_sides> inward_speed_inf = {};  // by Side: the free stream's into it
  PressureSideNodes nodes;
  Kokkos::View<const long long*, DeviceType> gradients;  // g_i in nodes' units, at nodes.entry(i, j)
  real_t hx = 0, hy = 0, p_inf = 0, rho_inf = 0, gamma = 0;
  index_t row_stride = 0;  // nodes_x

  SidePressure() = default;  // no pressure side (step 9's bands hold none)
  SidePressure(const GridSlab& slab, const std::array<BoundaryType, num_sides>& side_type, const GasState& free_stream,
               real_t gamma_, const PressureSideNodes& nodes_, const Kokkos::View<long long*, DeviceType>& gradients_)
      : left(pressure_side(side_type[left_side])),
        right(pressure_side(side_type[right_side])),
        bottom(pressure_side(side_type[bottom_side])),
        top(pressure_side(side_type[top_side])),
        nodes(nodes_),
        gradients(gradients_),
        hx(slab.geometry.spacing_x),
        hy(slab.geometry.spacing_y),
        p_inf(free_stream.pressure),
        rho_inf(free_stream.density),
        gamma(gamma_),
        row_stride(slab.geometry.nodes_x) {
    for (int s = 0; s < num_sides; ++s) {
      inflow[s] = side_type[s] == BoundaryType::inflow;
      inward_speed_inf[s] = inward_speed(s, free_stream.velocity_x, free_stream.velocity_y);
    }
  }

  // The momentum of node `node` (global node gi, gj) into side s, as the conditions leave it: where
  // the node lies on an inflow side's line too (a corner) the free stream's, m v_inf . n, which this
  // launch writes there, so that no thread reads it half written.
  KOKKOS_INLINE_FUNCTION real_t inward_momentum(const NodeFieldsView& state, int s, index_t node, index_t gi,
                                                index_t gj) const {
    const bool on_inflow = (inflow[left_side] && gi <= 0) || (inflow[right_side] && gi >= nodes.cells_x) ||
                           (inflow[bottom_side] && gj <= 0) || (inflow[top_side] && gj >= nodes.cells_y);
    return on_inflow ? state(node, GridFields::mass) * inward_speed_inf[s]
                     : inward_speed(s, state(node, GridFields::momentum_x), state(node, GridFields::momentum_y));
  }

  // The pressure of the gas outside side s at its node `side_node` (global node gi, gj): on a
  // far-field side the free stream enters (PressureSideNodes::inlet), from the Riemann invariants
  // of the free stream and of the gas at the node (far_field_boundary_pressure; p_inf where the
  // node holds no gas); the free stream's on the others.
  KOKKOS_INLINE_FUNCTION real_t outside_pressure(const NodeFieldsView& state, int s, index_t side_node, index_t gi,
                                                 index_t gj) const {
    if (!nodes.inlet[s]) return p_inf;
    const real_t m = state(side_node, GridFields::mass), volume = state(side_node, GridFields::volume);
    const real_t pressure_volume = state(side_node, GridFields::pressure_volume);
    if (!(m > 0 && volume > 0 && pressure_volume > 0)) return p_inf;
    return far_field_boundary_pressure(gamma, inward_momentum(state, s, side_node, gi, gj) / m, m / volume,
                                       pressure_volume / volume, inward_speed_inf[s], rho_inf, p_inf);
  }

  // Along one axis, of the dual cell of global node g (of `cells` cells, spacing h): the length
  // within the domain, and the length that holds gas (within the domain, or beyond a pressure side).
  KOKKOS_INLINE_FUNCTION static void dual_cell(index_t g, index_t cells, real_t h, bool low_is_pressure,
                                               bool high_is_pressure, real_t& inside, real_t& gas) {
    inside = g > 0 && g < cells ? h : (g == 0 || g == cells ? h / 2 : real_t(0));
    const bool beyond_outside = (g <= 0 && low_is_pressure) || (g >= cells && high_is_pressure);
    gas = beyond_outside ? h : inside;
  }

  KOKKOS_INLINE_FUNCTION void operator()(const NodeFieldsView& state, index_t node, index_t i, index_t j) const {
    int slot = 0;
    const index_t entry = nodes.entry(i, j, slot);
    if (entry < 0) return;  // (none: the pressure bands hold only nodes PressureSideNodes numbers)
    const int s = nodes.side[slot];
    // The node of the side's own line at the same place along it, and whether the gas leaves there.
    const bool across_x = s == left_side || s == right_side;
    const index_t side_i = across_x ? (s == left_side ? 0 : nodes.cells_x) - nodes.node_offset_x : i;
    const index_t side_j = across_x ? j : (s == bottom_side ? 0 : nodes.cells_y) - nodes.node_offset_y;
    const index_t side_node = node + (side_i - i) + (side_j - j) * row_stride;
    const bool side_node_held =
        side_i >= 0 && side_i < row_stride && side_j >= 0 && side_node < static_cast<index_t>(state.extent(0));
    const index_t side_gi = side_i + nodes.node_offset_x, side_gj = side_j + nodes.node_offset_y;
    const real_t outward = side_node_held ? -inward_momentum(state, s, side_node, side_gi, side_gj) : real_t(0);
    const index_t gi = i + nodes.node_offset_x, gj = j + nodes.node_offset_y;
    const bool in_domain = gi >= 0 && gi <= nodes.cells_x && gj >= 0 && gj <= nodes.cells_y;
    real_t fx = state(node, GridFields::force_x), fy = state(node, GridFields::force_y);
    real_t inside_x, gas_x, inside_y, gas_y;
    dual_cell(gi, nodes.cells_x, hx, left, right, inside_x, gas_x);
    dual_cell(gj, nodes.cells_y, hy, bottom, top, inside_y, gas_y);
    if (nodes.crossed[slot] && (outward > 0 || nodes.inlet[s] || nodes.outflow[s])) {
      const real_t p_outside = side_node_held ? outside_pressure(state, s, side_node, side_gi, side_gj) : p_inf;
      fx -= p_outside * nodes.unit * real_t(gradients(entry));
      fy -= p_outside * nodes.unit * real_t(gradients(entry + 1));
    } else {
      // The traction on the nodes of the domain's pressure sides (both at a corner of two), as
      // if the gauge had never reached here: the other lines keep their force.
      if (!in_domain) return;
      if (left && gi == 0) fx += outside_pressure(state, left_side, node, gi, gj) * inside_y;
      if (right && gi == nodes.cells_x) fx -= outside_pressure(state, right_side, node, gi, gj) * inside_y;
      if (bottom && gj == 0) fy += outside_pressure(state, bottom_side, node, gi, gj) * inside_x;
      if (top && gj == nodes.cells_y) fy -= outside_pressure(state, top_side, node, gi, gj) * inside_x;
    }
    const real_t outside_mass = rho_inf * (gas_x * gas_y - inside_x * inside_y);
    const real_t m = state(node, GridFields::mass);
    // (A node with neither particles nor gas outside, beyond a wall's corner: its force stays.)
    const real_t inertia_share = m + outside_mass > 0 ? m / (m + outside_mass) : real_t(1);
    state(node, GridFields::force_x) = fx * inertia_share;
    state(node, GridFields::force_y) = fy * inertia_share;
  }
};

// The sides' rectangles of one call: each pressure side's line (a corner node shared with an
// earlier pressure side is that side's, left and right coming before bottom and top, so that the
// traction of both sides acts once there), then each inflow side's band, then each slip wall's.
SideConditionBands side_condition_bands(const GridSlab& slab, const std::array<BoundaryType, num_sides>& side_type,
                                        bool with_pressure) {
  SideConditionBands bands;
  if (with_pressure) {
    // A corner's nodes (those of both sides' lines) are the left or right side's, as
    // PressureSideNodes::entry numbers them.
    const bool left = pressure_side(side_type[left_side]), right = pressure_side(side_type[right_side]);
    const index_t inner = PressureSideNodes::inner_layers;
    const index_t past_left = slab.local_node_x(inner + 1);
    const index_t before_right = slab.local_node_x(slab.global_cells_x - inner);
    for (int s = 0; s < num_sides; ++s) {
      if (!pressure_side(side_type[s])) continue;
      const Side side = static_cast<Side>(s);
      IndexRange2D band = condition_band(slab, side_type[s], side);
      if (side == bottom_side || side == top_side) {
        if (left) band.begin_x = std::max(band.begin_x, past_left);
        if (right) band.end_x = std::min(band.end_x, before_right);
      }
      bands.add(band, SideCondition::pressure, 0);
    }
  }
  for (const BoundaryType type : {BoundaryType::inflow, BoundaryType::slip_wall})
    for (int s = 0; s < num_sides; ++s)
      if (side_type[s] == type)
        bands.add(condition_band(slab, type, static_cast<Side>(s)),
                  type == BoundaryType::inflow ? SideCondition::inflow : SideCondition::slip_wall,
                  s == left_side || s == right_side ? 0 : 1);
  return bands;
}

// The sides' conditions, all in one launch (there was one a side and condition: 7 a step in a
// tunnel with an inflow, an outflow and two slip walls). A node that two rectangles hold (the
// corners of an inflow side and a slip wall, ghost nodes included) is the thread's of the first of
// them, which applies each condition that holds the node in the rectangles' order, as the launches
// one after the other did: each node has one writer, and the same bits.
// - pressure (outflow, far field): SidePressure on the force;
// - inflow: the node velocity is the free stream, momentum = m v_inf, and (with_force) no force;
// - slip wall: the normal component of the momentum, and (with_force) of the force, zeroed.
void apply_side_conditions(const GridGeometry& geo, const SideConditionBands& bands, const SidePressure& pressure,
                           const GasState& free_stream, const NodeFieldsView& momentum, int column_x,
                           const NodeFieldsView& state, bool with_force) {
  const index_t total = bands.first[bands.count];
  if (total == 0) return;
  const real_t vx = free_stream.velocity_x, vy = free_stream.velocity_y;
  Kokkos::parallel_for(
      "side_conditions", Kokkos::RangePolicy<ExecutionSpace>(0, total), KOKKOS_LAMBDA(const index_t k) {
        int b = 0;
        while (k >= bands.first[b + 1]) ++b;
        const IndexRange2D& band = bands.band[b];
        const index_t in_band = k - bands.first[b];  // (the node's place in its rectangle)
        const index_t i = band.i_of(in_band), j = band.j_of(in_band);
        for (int earlier = 0; earlier < b; ++earlier)
          if (bands.band[earlier].contains(i, j)) return;  // that rectangle's thread takes the node
        const index_t node = geo.node_index(i, j);
        for (int c = b; c < bands.count; ++c) {
          if (!bands.band[c].contains(i, j)) continue;
          switch (bands.condition[c]) {
            case SideCondition::pressure:
              pressure(state, node, i, j);
              break;
            case SideCondition::inflow: {
              const real_t m = state(node, GridFields::mass);
              momentum(node, column_x) = m * vx;
              momentum(node, column_x + 1) = m * vy;
              if (with_force) {
                state(node, GridFields::force_x) = 0;
                state(node, GridFields::force_y) = 0;
              }
              break;
            }
            case SideCondition::slip_wall:
              momentum(node, column_x + bands.normal_axis[c]) = 0;
              if (with_force) state(node, GridFields::force_x + bands.normal_axis[c]) = 0;
              break;
          }
        }
      });
}

// What the conditions remove of a vector a (momentum or force) on obstacle node k, whose row of
// ObstacleGrid::obstacle_normals is `normals`: removed_n along its normal n and removed_m along the
// second normal m (0 but on a convex vertex). Inside, the whole normal part; on a face, an inward
// normal part only (eqs. 21-22; remove_normal_component below says why); on a convex vertex, each
// face's inward part of the share of the node's gas beside that face (the node's gas is split
// between the faces; with the faces' mean normal instead, a diamond aerofoil's leading edge
// stopped the gas it parts, whose heat and slowness then ran along both faces: README, Validation).
// The body's force counts what goes (ObstacleForceSums).
struct RemovedNormalParts {
  real_t n_x, n_y, m_x = 0, m_y = 0;
  real_t removed_n = 0, removed_m = 0;

  KOKKOS_INLINE_FUNCTION RemovedNormalParts(const NodeFieldsView& normals, index_t k, real_t a_x, real_t a_y)
      : n_x(normals(k, ObstacleGrid::normal_x_column)), n_y(normals(k, ObstacleGrid::normal_y_column)) {
    const real_t placement = normals(k, ObstacleGrid::placement_column);
    const real_t a_n = a_x * n_x + a_y * n_y;
    if (placement != ObstacleGrid::on_convex_vertex) {
      removed_n = placement == ObstacleGrid::on_face && a_n > 0 ? real_t(0) : a_n;
      return;
    }
    m_x = normals(k, ObstacleGrid::second_normal_x_column);
    m_y = normals(k, ObstacleGrid::second_normal_y_column);
    const real_t share = normals(k, ObstacleGrid::face_share_column);
    const real_t a_m = a_x * m_x + a_y * m_y;
    removed_n = a_n < 0 ? share * a_n : real_t(0);
    removed_m = a_m < 0 ? share * a_m : real_t(0);
  }
};

// On the nodes inside an obstacle the whole normal component goes, as on the domain's slip walls:
// an inviscid gas keeps to a wall (v.n = 0 there) while its pressure is above zero. The paper's
// eqs. 21-22 remove only the inward component, as for a solid body that may come off a wall; with
// them the gas left the transonic aerofoil's aft upper surface and the Mach 3 cylinder's back, and
// splitting filled the gaps with particles split again and again (to 2^-37 of a placed particle's
// mass and a density of 7e-12 in the cylinder at t = 3; the aerofoil once failed with a negative
// density at t = 0.27), which also shrank the time step (README, Wind tunnel).
// On the nodes on the surface (a face along a grid line), whose hats lie half in the gas, only the
// inward part goes (eqs. 21-22): the gas's own pressure there decides whether it stays. Held
// there as well, it could not leave a face the flow cannot turn round (a Mach 3 stream turns at
// most 81 degrees before its pressure falls to zero): behind a plate's blunt end on a node line
// the gas held to the end face, and light particles there reached |v| + c = 204 and a pressure of
// 9090, 3751 steps to t = 2 (995 now; README, Wind tunnel).
// (And of the vector from second_column_x, where that is not negative: the momentum and the force
// in one launch.)
void remove_normal_component(const ObstacleGrid& obstacles, const NodeFieldsView& fields, int column_x,
                             int second_column_x = -1) {
  const index_t count = obstacles.num_obstacle_nodes();
  if (count == 0) return;
  const IndexView nodes = obstacles.obstacle_nodes;
  const NodeFieldsView normals = obstacles.obstacle_normals;
  Kokkos::parallel_for(
      "obstacle_nodes", Kokkos::RangePolicy<ExecutionSpace>(0, count), KOKKOS_LAMBDA(const index_t k) {
        const index_t node = nodes(k);
        const auto remove = [&](int column) {
          const RemovedNormalParts removed(normals, k, fields(node, column), fields(node, column + 1));
          fields(node, column) -= removed.removed_n * removed.n_x;
          fields(node, column + 1) -= removed.removed_n * removed.n_y;
          if (removed.removed_m == 0) return;
          fields(node, column) -= removed.removed_m * removed.m_x;
          fields(node, column + 1) -= removed.removed_m * removed.m_y;
        };
        remove(column_x);
        if (second_column_x >= 0) remove(second_column_x);
      });
}

// The sums of add_obstacle_forces below, 2 o + axis for obstacle o, in one reduction (one launch
// and one wait on a GPU, where there were two an obstacle); each sums the same terms in the same
// order as a reduction of its own.
struct ObstacleForceSums {
  using value_type = double[];
  unsigned value_count;  // 2 x the obstacles (Kokkos' name: the length of an array reduction)
  IndexView nodes, of_node;
  NodeFieldsView normals, state;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, value_type sums) const {
    // A node another slab owns (-1) is that slab's rank's to count. (Its terms at 2 x -1 would
    // fall outside the totals: on a GPU, where Kokkos lays the threads' totals side by side in
    // shared memory, into the previous thread's.)
    const index_t o = of_node(k);
    if (o < 0) return;
    const index_t node = nodes(k);
    const RemovedNormalParts removed(normals, k, state(node, GridFields::force_x), state(node, GridFields::force_y));
    sums[2 * o] += removed.removed_n * removed.n_x;
    sums[2 * o + 1] += removed.removed_n * removed.n_y;
    if (removed.removed_m == 0) return;
    sums[2 * o] += removed.removed_m * removed.m_x;
    sums[2 * o + 1] += removed.removed_m * removed.m_y;
  }
};

// The force the gas exerts on each obstacle: the normal component of the force that the
// condition above is about to remove on its nodes, summed over the nodes this slab owns. (Each
// particle's velocity changes by dt times the interpolated force per unit mass, so the gas's
// momentum changes by dt times the sum of the node forces: what the condition removes, the body
// takes.)
void add_obstacle_forces(const ObstacleGrid& obstacles, const NodeFieldsView& state, ObstacleForces& forces) {
  const index_t count = obstacles.num_obstacle_nodes();
  const size_t num_obstacles = static_cast<size_t>(obstacles.num_obstacles);
  forces.x.assign(num_obstacles, 0.0);
  forces.y.assign(num_obstacles, 0.0);
  if (count == 0) return;
  std::vector<double> sums(2 * num_obstacles, 0.0);
  sum_in_fixed_order("obstacle_force", count,
                     ObstacleForceSums{static_cast<unsigned>(sums.size()), obstacles.obstacle_nodes,
                                       obstacles.obstacle_of_node, obstacles.obstacle_normals, state},
                     sums.data());
  for (size_t o = 0; o < num_obstacles; ++o) {
    forces.x[o] = sums[2 * o];
    forces.y[o] = sums[2 * o + 1];
  }
}

// The obstacles press on the gas with its pressure (a struct rather than a lambda in a private
// member: CUDA forbids those). A node whose basis function reaches into a body feels the
// particles' pressure unopposed from the side the body takes: its force sum_p (P + Q) (M / rho)
// grad phi_i holds p g_i, g_i = sum_p (M / rho) grad phi_i = \int_covered grad N_i = -\int_uncovered
// grad N_i, a pull towards the space the particles leave uncovered. Along a flat wall on a node
// line the pull is normal to it and the wall's condition takes it; elsewhere (a corner, a curved or
// oblique wall, the nodes outside a body) part of it runs along the wall, or acts where no
// condition takes it: gas at rest at pressure 1 round a cylinder of radius 0.25 (100 x 100 cells
// on [0, 2]^2, 2 x 2 particles a cell) reached 0.64 and pressures from 0.68 to 2.1 by t = 0.1,
// round a square on the grid's lines 0.78 (it ran along the faces from the corners), round one off
// them 0.96. So the body presses back as gas at the node's pressure p_i (sum_p phi_i P M / rho over
// sum_p phi_i M / rho) filling the uncovered space would, f_i -= p_i g_i (the pressure sides'
// gauge, SidePressure): nothing to gas at one pressure, however its particles end at the body.
// But only the body's space is the body's: where the gas has come off a wall, the gap between is
// empty, and must draw the gas back. The gauge is therefore scaled by how much of the node's gas
// space the particles fill, min(1, sum_p phi_i M / rho over \int_gas N_i, ObstacleGrid::
// node_gas_volume). With the whole gauge the Mach 3 diamond aerofoil's gas came off its lower rear
// face behind the crest's expansion (a gap three cells deep, the face's median pressure 11 %
// low); with the body's space alone in its place (p_i \int_body grad N_i, sampled on 16 x 16
// points a cell), gas at rest still ran along a square off the grid's lines (1.06 by t = 0.3):
// particles placed on sub-cell centres end on sub-cell lines, short of a body or over it. The
// nodes are ObstacleGrid::body_nodes, within reach of the space beside a body (taking only those
// whose basis functions reach into a body, the diamond's rear faces measured -5.5 % and -7.4 %,
// against -3.2 % and -3.0 % now).
// What the gas gains the body loses (ObstaclePressureReaction); the energy budget counts the work
// (conditioned_nodes).
struct ObstaclePressure {
  ObstaclePressureNodes nodes;
  Kokkos::View<const long long*, DeviceType> gradients;
  NodeFieldsView state;
  RealView node_gas_volume;
  // The force node k's gas gains, (fx, fy); none where no particle covers it.
  KOKKOS_INLINE_FUNCTION void force(index_t k, real_t& fx, real_t& fy) const {
    const index_t node = nodes.nodes(k);
    const real_t volume = state(node, GridFields::volume);
    const real_t pressure = volume > 0 ? state(node, GridFields::pressure_volume) / volume : real_t(0);
    const real_t gx = nodes.unit * real_t(gradients(2 * k)), gy = nodes.unit * real_t(gradients(2 * k + 1));
    const real_t gas_volume = absolute_value(node_gas_volume(node));
    const real_t filled = gas_volume > 0 && volume < gas_volume ? volume / gas_volume : real_t(1);
    fx = -pressure * filled * gx;
    fy = -pressure * filled * gy;
  }
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k) const {
    real_t fx, fy;
    force(k, fx, fy);
    const index_t node = nodes.nodes(k);
    state(node, GridFields::force_x) += fx;
    state(node, GridFields::force_y) += fy;
  }
};

// The reaction of ObstaclePressure on each obstacle, 2 o + axis for obstacle o, over the nodes this
// slab owns (ObstacleForceSums' array reduction).
struct ObstaclePressureReaction {
  using value_type = double[];
  unsigned value_count;
  ObstaclePressure pressure;
  KOKKOS_INLINE_FUNCTION void operator()(const index_t k, value_type sums) const {
    const index_t o = pressure.nodes.obstacle(k);
    if (o < 0) return;
    real_t fx, fy;
    pressure.force(k, fx, fy);
    sums[2 * o] -= fx;
    sums[2 * o + 1] -= fy;
  }
};

// PressureSideNodes::node_entry. (A function of its own: nvcc takes no device lambda in a
// constructor.)
Kokkos::View<int*, DeviceType> entries_by_node(const PressureSideNodes& sides, const GridGeometry& geometry) {
  const Kokkos::View<int*, DeviceType> entry(Kokkos::view_alloc(Kokkos::WithoutInitializing, "pressure_side_node_entry"),
                                             geometry.num_nodes());
  Kokkos::parallel_for(
      "pressure_side_node_entry", Kokkos::RangePolicy<ExecutionSpace>(0, geometry.num_nodes()),
      KOKKOS_LAMBDA(const index_t node) {
        entry(node) = static_cast<int>(sides.entry(geometry.node_i_of(node), geometry.node_j_of(node)));
      });
  return entry;
}

}  // namespace

void SideConditionBands::add(const IndexRange2D& nodes, SideCondition c, int axis) {
  if (nodes.empty()) return;
  band[count] = nodes;
  condition[count] = c;
  normal_axis[count] = axis;
  first[count + 1] = first[count] + nodes.size();
  ++count;
}

BoundaryConfig acting_boundaries(const CaseConfig& config) {
  BoundaryConfig sides = config.boundaries;
  const GasState& inf = sides.free_stream;
  const real_t c_inf = sound_speed(config.physics.gamma, inf.pressure, inf.density);
  BoundaryType* type[num_sides] = {&sides.left, &sides.right, &sides.bottom, &sides.top};
  for (int s = 0; s < num_sides; ++s)
    if (*type[s] == BoundaryType::far_field && inward_speed(s, inf.velocity_x, inf.velocity_y) >= c_inf)
      *type[s] = BoundaryType::inflow;
  return sides;
}

GridBoundaryConditions::GridBoundaryConditions(const CaseConfig& config, const GridSlab& slab,
                                               const ObstacleGrid& obstacles)
    : slab_(slab),
      side_type_(acting_boundaries(config).side_types()),
      free_stream_(config.boundaries.free_stream),
      gamma_(config.physics.gamma),
      obstacles_(obstacles),
      bands_with_pressure_(side_condition_bands(slab, side_type_, /*with_pressure=*/true)),
      bands_without_pressure_(side_condition_bands(slab, side_type_, /*with_pressure=*/false)),
      pressure_side_nodes_(slab, side_type_, free_stream_),
      pressure_side_gradients_("pressure_side_gradients", pressure_side_nodes_.entries),
      pressure_side_gradients_host_(host_mirror(pressure_side_gradients_)),
      obstacle_pressure_nodes_(slab, obstacles, pressure_side_nodes_),
      obstacle_pressure_gradients_("obstacle_pressure_gradients", 2 * obstacle_pressure_nodes_.count) {
  // The cells' marks, node by node on the host, once (BoundaryVolumeGradients).
  const GridGeometry& geo = slab.geometry;
  const auto obstacle_entry = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), obstacle_pressure_nodes_.entry);
  Kokkos::View<unsigned char*, DeviceType> cells("volume_gradient_cells", geo.num_cells());
  const auto cells_host = Kokkos::create_mirror_view(cells);
  Kokkos::deep_copy(cells_host, 0);
  constexpr index_t r = widest_stencil_reach;
  for (index_t j = 0; j < geo.nodes_y; ++j)
    for (index_t i = 0; i < geo.nodes_x; ++i) {
      const index_t node = geo.node_index(i, j);
      int slot = 0;
      const bool side_node = pressure_side_nodes_.entry(i, j, slot) >= 0;
      const unsigned char mark =
          (side_node && pressure_side_nodes_.crossed[slot] ? BoundaryVolumeGradients::reaches_side : 0) |
          (obstacle_entry.extent(0) > 0 && obstacle_entry(node) >= 0 ? BoundaryVolumeGradients::reaches_obstacle : 0);
      if (mark == 0) continue;
      // The cells i - r .. i + r - 1 (and the same rows) whose particles may reach node (i, j).
      for (index_t cj = std::max<index_t>(j - r, 0); cj < std::min<index_t>(j + r, geo.cells_y()); ++cj)
        for (index_t ci = std::max<index_t>(i - r, 0); ci < std::min<index_t>(i + r, geo.cells_x()); ++ci)
          cells_host(ci + geo.cells_x() * cj) |= mark;
    }
  Kokkos::deep_copy(cells, cells_host);
  volume_gradient_cells_ = cells;
}

ObstaclePressureNodes::ObstaclePressureNodes(const GridSlab& slab, const ObstacleGrid& obstacles,
                                             const PressureSideNodes& side_nodes)
    : GradientUnits(slab.cell_size()) {
  const GridGeometry& geo = slab.geometry;
  const auto band_nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), obstacles.body_nodes);
  const auto band_obstacle = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), obstacles.body_node_obstacle);
  std::vector<size_t> kept;
  for (size_t k = 0; k < band_nodes.extent(0); ++k) {
    const index_t node = band_nodes(k);
    // (A pressure side's gauge already stands for every space its particles leave uncovered.)
    if (side_nodes.entry(geo.node_i_of(node), geo.node_j_of(node)) < 0) kept.push_back(k);
  }
  count = static_cast<index_t>(kept.size());
  entry = Kokkos::View<int*, DeviceType>("obstacle_pressure_entry", obstacles.num_obstacles > 0 ? geo.num_nodes() : 0);
  auto entry_host = Kokkos::create_mirror_view(entry);
  Kokkos::deep_copy(entry_host, -1);
  for (size_t k = 0; k < kept.size(); ++k) entry_host(band_nodes(kept[k])) = static_cast<int>(2 * k);
  Kokkos::deep_copy(entry, entry_host);
  nodes = IndexView("obstacle_pressure_nodes", kept.size());
  obstacle = IndexView("obstacle_pressure_obstacle", kept.size());
  auto nodes_host = host_mirror(nodes);
  auto obstacle_host = host_mirror(obstacle);
  for (size_t k = 0; k < kept.size(); ++k) {
    nodes_host(k) = band_nodes(kept[k]);
    obstacle_host(k) = band_obstacle(kept[k]);
  }
  Kokkos::deep_copy(nodes, nodes_host);
  Kokkos::deep_copy(obstacle, obstacle_host);
}

PressureSideNodes::PressureSideNodes(const GridSlab& slab, const std::array<BoundaryType, num_sides>& side_type,
                                     const GasState& free_stream)
    : GradientUnits(slab.cell_size()),
      node_offset_x(slab.node_offset_x),
      node_offset_y(slab.node_offset_y),
      cells_x(slab.global_cells_x),
      cells_y(slab.global_cells_y) {
  for (int s = 0; s < num_sides; ++s) {
    if (!pressure_side(side_type[s])) continue;
    side[count] = s;
    const real_t free_stream_inward = inward_speed(s, free_stream.velocity_x, free_stream.velocity_y);
    inlet[s] = far_field_inlet(side_type[s], free_stream_inward);
    outflow[s] = side_type[s] == BoundaryType::outflow;
    crossed[count] = side_type[s] == BoundaryType::outflow || free_stream_inward < 0 || inlet[s];
    any_crossed |= crossed[count];
    first_entry[count] = entries;
    entries += 2 * layers * nodes_along(s == left_side || s == right_side ? cells_y : cells_x);
    ++count;
  }
  node_entry = entries_by_node(*this, slab.geometry);
}

void GridBoundaryConditions::clear_pressure_side_gradients() const { fill_in_order(pressure_side_gradients_, 0LL); }

void GridBoundaryConditions::sum_pressure_side_gradients(const ParallelContext& context) const {
  if (!context.distributed() || pressure_side_nodes_.entries == 0) return;
  Kokkos::deep_copy(pressure_side_gradients_host_, pressure_side_gradients_);
  context.sum_in_place(pressure_side_gradients_host_.data(), static_cast<int>(pressure_side_nodes_.entries));
  Kokkos::deep_copy(pressure_side_gradients_, pressure_side_gradients_host_);
}

void GridBoundaryConditions::clear_obstacle_pressure_gradients() const {
  fill_in_order(obstacle_pressure_gradients_, 0LL);
}

void GridBoundaryConditions::sum_obstacle_pressure_gradients(const HaloExchange& halo,
                                                             const NodeFieldsView& scratch) const {
  if (!halo.active() || obstacles_.num_obstacles == 0) return;
  // Through two node columns, as doubles: integers below 2^53, so that the sum of the two slabs'
  // shares is exact and the same bits on both.
  const ObstaclePressureNodes nodes = obstacle_pressure_nodes_;
  const Kokkos::View<long long*, DeviceType> gradients = obstacle_pressure_gradients_;
  Kokkos::parallel_for(
      "obstacle_pressure_gradients_to_nodes", Kokkos::RangePolicy<ExecutionSpace>(0, scratch.extent(0)),
      KOKKOS_LAMBDA(const index_t node) {
        const int e = nodes.entry(node);
        scratch(node, 0) = e < 0 ? real_t(0) : static_cast<real_t>(gradients(e));
        scratch(node, 1) = e < 0 ? real_t(0) : static_cast<real_t>(gradients(e + 1));
      });
  halo.sum_shared_nodes(scratch, 0, 2);
  Kokkos::parallel_for(
      "obstacle_pressure_gradients_from_nodes", Kokkos::RangePolicy<ExecutionSpace>(0, nodes.count),
      KOKKOS_LAMBDA(const index_t k) {
        const index_t node = nodes.nodes(k);
        gradients(2 * k) = static_cast<long long>(scratch(node, 0));
        gradients(2 * k + 1) = static_cast<long long>(scratch(node, 1));
      });
}

void GridBoundaryConditions::apply_to_momentum_and_force(const NodeFieldsView& state, ObstacleForces* forces) const {
  // The obstacles' pressure first: the sides' conditions then act on the force it leaves (a slip
  // wall's normal component, an inflow side's whole force).
  const ObstaclePressure obstacle_pressure{obstacle_pressure_nodes_, obstacle_pressure_gradients_, state,
                                           obstacles_.node_gas_volume};
  std::vector<double> reaction(2 * static_cast<size_t>(obstacles_.num_obstacles), 0.0);
  if (obstacle_pressure_nodes_.count > 0) {
    if (forces)
      sum_in_fixed_order("obstacle_pressure_reaction", obstacle_pressure_nodes_.count,
                         ObstaclePressureReaction{static_cast<unsigned>(reaction.size()), obstacle_pressure},
                         reaction.data());
    Kokkos::parallel_for("obstacle_pressure", Kokkos::RangePolicy<ExecutionSpace>(0, obstacle_pressure_nodes_.count),
                         obstacle_pressure);
  }
  apply_side_conditions(slab_.geometry, bands_with_pressure_,
                        SidePressure(slab_, side_type_, free_stream_, gamma_, pressure_side_nodes_, pressure_side_gradients_),
                        free_stream_, state, GridFields::momentum_x, state, /*with_force=*/true);
  if (forces) {
    add_obstacle_forces(obstacles_, state, *forces);
    for (size_t o = 0; o < forces->x.size(); ++o) {
      forces->x[o] += reaction[2 * o];
      forces->y[o] += reaction[2 * o + 1];
    }
  }
  remove_normal_component(obstacles_, state, GridFields::momentum_x, GridFields::force_x);
}

void GridBoundaryConditions::apply_to_momentum(const NodeFieldsView& momentum, int column_x,
                                               const NodeFieldsView& state) const {
  apply_side_conditions(slab_.geometry, bands_without_pressure_, SidePressure(), free_stream_, momentum, column_x,
                        state, /*with_force=*/false);
  remove_normal_component(obstacles_, momentum, column_x);
}

IndexView GridBoundaryConditions::conditioned_nodes(const IndexRange2D& within) const {
  const GridGeometry& geo = slab_.geometry;
  std::vector<index_t> nodes;
  const auto add = [&](index_t i, index_t j) {
    if (within.contains(i, j)) nodes.push_back(geo.node_index(i, j));
  };
  for (int s = 0; s < num_sides; ++s)
    for (const IndexRange2D& line : condition_lines(slab_, side_type_[s], static_cast<Side>(s)))
      for (index_t j = line.begin_y; j < line.end_y; ++j)
        for (index_t i = line.begin_x; i < line.end_x; ++i) add(i, j);
  const auto obstacle_nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), obstacles_.obstacle_nodes);
  for (index_t k = 0; k < obstacles_.num_obstacle_nodes(); ++k) {
    const index_t node = obstacle_nodes(k);
    add(geo.node_i_of(node), geo.node_j_of(node));
  }
  const auto pressure_nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), obstacle_pressure_nodes_.nodes);
  for (index_t k = 0; k < obstacle_pressure_nodes_.count; ++k) {
    const index_t node = pressure_nodes(k);
    add(geo.node_i_of(node), geo.node_j_of(node));
  }
  std::sort(nodes.begin(), nodes.end());
  nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
  return to_device_indices("conditioned_nodes", nodes);
}

ParticleBoundaries::ParticleBoundaries(const CaseConfig& config, const GridSlab& slab,
                                       const ObstacleGrid& obstacle_grid)
    : domain(slab),
      grid(slab.geometry),
      obstacles(obstacle_grid.obstacles),
      cell_near_obstacle(obstacle_grid.cell_near_obstacle),
      near_x_min(obstacle_grid.near_x_min),
      near_x_max(obstacle_grid.near_x_max),
      near_y_min(obstacle_grid.near_y_min),
      near_y_max(obstacle_grid.near_y_max),
      has_obstacles(!obstacle_grid.obstacles.empty()),
      surface_offset(real_t(1e-6) * slab.cell_size()) {
  const auto types = acting_boundaries(config).side_types();
  std::copy(types.begin(), types.end(), side_type);
}

double apply_particle_rules(const ParticleBoundaries& boundaries, const ParticleState& particles, real_t dt,
                            ObstacleForces* forces) {
  const ParticleBoundaries rules = boundaries;
  const ParticleState pt = particles;
  const int num_obstacles = forces ? static_cast<int>(forces->x.size()) : 0;
  // The kinetic energy the rules took (total 0) and each obstacle's impulse (1 + 2 o, 2 + 2 o),
  // over the particles a rule may reach: those ParticleBoundaries does not leave alone, which on
  // CPUs is tested as vector lanes (two loads and eight comparisons a particle) before the rules run
  // for those alone (Kokkos' loop over the particles one by one stayed scalar and branched on every
  // particle). Few particles touch an obstacle in a step.
  std::vector<double> totals(static_cast<size_t>(1 + 2 * num_obstacles));
  const real_t* const x = pt.position_x.data();
  const real_t* const y = pt.position_y.data();
  sums_over_indices_where(
      "particle_move", pt.count, static_cast<int>(totals.size()),
      KOKKOS_LAMBDA(const index_t p) { return !rules.leaves_alone(x[p], y[p]); },
      KOKKOS_LAMBDA(const index_t p, double* sums) {
        real_t ix = 0, iy = 0;
        index_t o = 0;
        double lost = 0;
        const bool hit = rules.apply(p, pt, ix, iy, o, lost);
        // Only where a rule took some: the rules store into particle fields, so the compiler keeps
        // the sums in memory, and an addition for every particle chained each to the last.
        if (lost != 0) sums[0] += lost;
        if (hit && o < num_obstacles) {
          sums[1 + 2 * o] += ix;
          sums[2 + 2 * o] += iy;
        }
      },
      totals.data());
  for (int o = 0; o < num_obstacles; ++o) {
    forces->x[static_cast<size_t>(o)] += totals[static_cast<size_t>(1 + 2 * o)] / dt;
    forces->y[static_cast<size_t>(o)] += totals[static_cast<size_t>(2 + 2 * o)] / dt;
  }
  return totals[0];
}

void locate_particles(const ParticleBoundaries& boundaries, const ParticleState& particles) {
  // A loop of its own: the rules' loop is branchy scalar code, and with the cells in it the two
  // took longer than apart (3.8-4.1 against 3.3 ms for 881 000 particles, measured). In vector
  // lanes (the locator selects, not branches): 3.8 -> 0.77 ms on one thread at 903 000 particles.
  const ParticleLocator locate = boundaries.locator();
  const RealView x = particles.position_x, y = particles.position_y;
  const IndexView cell = particles.cell;
  for_each_index_in_lanes("particle_cells", particles.count,
                          KOKKOS_LAMBDA(const index_t p) { cell(p) = locate(x(p), y(p)); });
}

double apply_particle_boundaries(const ParticleBoundaries& boundaries, const ParticleState& particles, real_t dt,
                                 ObstacleForces* forces) {
  const double stopped = apply_particle_rules(boundaries, particles, dt, forces);
  locate_particles(boundaries, particles);
  return stopped;
}

}  // namespace mpmflow
