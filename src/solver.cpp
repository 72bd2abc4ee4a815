#include "solver.hpp"

#include <limits>
#include <sstream>
#include <type_traits>

#include "boundary_conditions.hpp"
#include "gas_physics.hpp"
#include "kernels/particle_sort.hpp"
#include "kernels/reductions.hpp"
#include "kernels/transfer_kernels.hpp"

namespace mpmflow {
namespace {

// ---- On-the-fly functors of Algorithm 1 (the paper's I, zeta, eta and theta) ------------------

// P2G(I, M), P2G(I, M Vx), P2G(I, M Vy)
struct MassAndMomentum {
  static constexpr int num_components = 3;
  RealView mass, velocity_x, velocity_y;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&value)[3]) const {
    value[0] = mass(p);
    value[1] = mass(p) * velocity_x(p);
    value[2] = mass(p) * velocity_y(p);
  }
};

// P2G(I, M V): the momentum remap of step 8.
struct Momentum {
  static constexpr int num_components = 2;
  RealView mass, velocity_x, velocity_y;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&value)[2]) const {
    value[0] = mass(p) * velocity_x(p);
    value[1] = mass(p) * velocity_y(p);
  }
};

// P2GD(zeta / eta, P, Q, M, rho): the internal force f_i = sum_p (P+Q) (M/rho) grad phi_i (eq. 13).
struct InternalForce {
  static constexpr int num_components = 2;
  RealView pressure, viscosity, mass, density;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, real_t (&vector)[2][2]) const {
    const real_t stress_times_volume = (pressure(p) + viscosity(p)) * mass(p) / density(p);
    vector[0][0] = stress_times_volume;  // zeta: x force component pairs with d/dx
    vector[0][1] = 0;
    vector[1][0] = 0;                    // eta: y force component pairs with d/dy
    vector[1][1] = stress_times_volume;
  }
};

// theta(a, m) = a / m on a node: 1 / m where the node carries mass, 0 on (nearly) empty nodes.
KOKKOS_INLINE_FUNCTION real_t per_unit_node_mass(real_t node_mass, real_t mass_threshold) {
  return node_mass > mass_threshold ? real_t(1) / node_mass : real_t(0);
}

// The G2P node functor: N adjacent columns of a View, read as they are.
template <int N>
struct NodeColumns {
  static constexpr int num_components = N;
  NodeFieldsView fields;
  int first_column;
  KOKKOS_INLINE_FUNCTION void operator()(index_t node, real_t (&value)[N]) const {
    for (int c = 0; c < N; ++c) value[c] = fields(node, first_column + c);
  }
};

// Sink of step 6-7: keep V-bar for the move, update V with the interpolated acceleration.
struct StoreGridVelocityAndAccelerate {
  RealView grid_velocity_x, grid_velocity_y, velocity_x, velocity_y;
  real_t dt;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&value)[4]) const {
    grid_velocity_x(p) = value[0];
    grid_velocity_y(p) = value[1];
    velocity_x(p) += dt * value[2];
    velocity_y(p) += dt * value[3];
  }
};

// Steps 6-8 for one particle, for the fused kernel: the sink above, then the particle's new
// momentum M V' for the remap P2G.
struct AccelerateThenCarryMomentum {
  static constexpr int num_components = 2;
  StoreGridVelocityAndAccelerate store;
  RealView mass;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&value)[4], real_t (&momentum)[2]) const {
    store(p, value);
    momentum[0] = mass(p) * store.velocity_x(p);
    momentum[1] = mass(p) * store.velocity_y(p);
  }
};

// Sink of step 10: density, energy, pressure and artificial viscosity from div V; the particle
// domain's stretches (diagonal of the deformation gradient, used by GIMP) from dVx/dx and dVy/dy.
struct UpdateThermodynamics {
  RealView density, specific_energy, pressure, viscosity, stretch_x, stretch_y;
  real_t dt, gamma, cell_size, c0, c1;
  KOKKOS_INLINE_FUNCTION void operator()(index_t p, const real_t (&gradient)[2][2]) const {
    const real_t div_v = gradient[0][0] + gradient[1][1];
    stretch_x(p) *= 1 + dt * gradient[0][0];
    stretch_y(p) *= 1 + dt * gradient[1][1];
    const real_t rho = density(p);
    const real_t q = artificial_viscosity(rho, sound_speed(gamma, pressure(p), rho), cell_size, div_v, c0, c1);
    const real_t e_new = advanced_specific_energy(specific_energy(p), dt, pressure(p), q, rho, div_v);
    const real_t rho_new = advanced_density(rho, dt, div_v);
    specific_energy(p) = e_new;
    density(p) = rho_new;
    pressure(p) = perfect_gas_pressure(gamma, rho_new, e_new);
    viscosity(p) = q;
  }
};

// The shape policy with the particle Views of now (migration may have reallocated them).
LinearShape current_shape(const LinearShape& shape, const ParticleState&) { return shape; }
GimpShape current_shape(GimpShape shape, const ParticleState& particles) {
  shape.stretch_x = particles.domain_stretch_x;
  shape.stretch_y = particles.domain_stretch_y;
  return shape;
}

}  // namespace

class Solver::Stepper {
 public:
  virtual ~Stepper() = default;
  virtual void advance(Solver& solver, real_t dt) = 0;
  virtual void project_mass_and_momentum(Solver& solver) = 0;
  virtual P2GStrategy strategy() const = 0;
  virtual size_t scatter_copy_bytes() const = 0;
};

namespace {

// How the step's P2G passes accumulate (numerics/p2g). Through ScatterViews, duplicated (a copy
// of the node fields per thread, summed at the end) or atomic: all particles at once.
template <class Duplication>
class ScatterAccumulation {
 public:
  explicit ScatterAccumulation(const GridFields& fields) : state_(fields.state), remap_(fields.momentum_remap) {}
  void prepare(const ParticleState&, const GridGeometry&) {}
  index_t traversal(const ParticleState& particles) const { return particles.count; }
  NodeScatterView<Duplication>& state() { return state_; }
  NodeScatterView<Duplication>& remap() { return remap_; }
  P2GStrategy strategy() const {
    return std::is_same<Duplication, Kokkos::Experimental::ScatterDuplicated>::value ? P2GStrategy::duplicated
                                                                                     : P2GStrategy::atomic;
  }
  // A duplicated ScatterView holds one copy of its target per thread (the target itself aside).
  size_t extra_bytes() const {
    if (!std::is_same<Duplication, Kokkos::Experimental::ScatterDuplicated>::value) return 0;
    const size_t copies = static_cast<size_t>(ExecutionSpace().concurrency());
    return copies * sizeof(real_t) * (state_.subview().span() + remap_.subview().span());
  }

 private:
  // Kept alive across steps: creating a duplicated ScatterView allocates a copy per thread.
  NodeScatterView<Duplication> state_;
  NodeScatterView<Duplication> remap_;
};

// Sorted and coloured: the particles grouped by cell (CellOrder, rebuilt every step since the
// particles move), then P2G colour by colour straight into the node fields. No copies, no
// atomics, and the same sums in the same order for any thread count: bitwise reproducible.
class ColouredAccumulation {
 public:
  explicit ColouredAccumulation(const GridFields& fields) : state_{fields.state}, remap_{fields.momentum_remap} {}
  void prepare(const ParticleState& particles, const GridGeometry& grid) {
    order_.build(particles.cell, particles.count, grid.num_cells());
    cells_ = {order_.cell_offset(), order_.particle(), grid.cells_x(), grid.cells_y()};
  }
  const ColouredCells& traversal(const ParticleState&) const { return cells_; }
  DirectNodeAccess& state() { return state_; }
  DirectNodeAccess& remap() { return remap_; }
  P2GStrategy strategy() const { return P2GStrategy::sorted; }
  size_t extra_bytes() const { return order_.bytes(); }

 private:
  DirectNodeAccess state_, remap_;
  CellOrder order_;
  ColouredCells cells_;
};

}  // namespace

template <class Accumulation, class Shape>
class Solver::ScatterStepper final : public Solver::Stepper {
 public:
  ScatterStepper(const GridFields& fields, const Shape& shape) : accumulation_(fields), shape_(shape) {}

  P2GStrategy strategy() const override { return accumulation_.strategy(); }
  void advance(Solver& solver, real_t dt) override;
  void project_mass_and_momentum(Solver& solver) override;
  size_t scatter_copy_bytes() const override { return accumulation_.extra_bytes(); }

 private:
  Accumulation accumulation_;
  Shape shape_;
};

template <class Accumulation, class Shape>
void Solver::ScatterStepper<Accumulation, Shape>::project_mass_and_momentum(Solver& solver) {
  const ParticleState& pt = solver.particles_;
  const NodeFieldsView state = solver.grid_fields_.state;
  Kokkos::deep_copy(state, real_t(0));
  accumulation_.prepare(pt, solver.slab_.geometry);
  p2g_begin(accumulation_.state(), state);
  p2g("p2g_mass_momentum", current_shape(shape_, pt), pt.locations(), accumulation_.traversal(pt),
      accumulation_.state(), GridFields::mass, MassAndMomentum{pt.mass, pt.velocity_x, pt.velocity_y});
  p2g_end(accumulation_.state(), state);
  solver.halo_->sum_shared_nodes(state, GridFields::mass, 3);
}

template <class Accumulation, class Shape>
void Solver::ScatterStepper<Accumulation, Shape>::advance(Solver& solver, real_t dt) {
  const CaseConfig& cfg = solver.config_;
  const GridSlab& slab = solver.slab_;
  const GridGeometry grid = slab.geometry;
  ParticleState& pt = solver.particles_;
  const Shape shape = current_shape(shape_, pt);
  const GridFields& fields = solver.grid_fields_;
  PhaseTimers& timers = solver.timers_;
  const ParticleLocations where = pt.locations();
  const index_t n = pt.count;
  const NodeFieldsView state = fields.state;
  const NodeFieldsView remap = fields.momentum_remap;

  {  // 2. grid reset
    auto t = timers.scope("grid_reset");
    Kokkos::deep_copy(state, real_t(0));
    Kokkos::deep_copy(remap, real_t(0));
  }
  {  // 3. mass, momentum and force P2G
    auto t = timers.scope("p2g_mass_momentum_force");
    accumulation_.prepare(pt, grid);
    p2g_begin(accumulation_.state(), state);
    // Fused: the paper's P2G(M), P2G(M V) and P2GD((P + Q) M / rho) in one pass over the particles.
    p2g_and_p2gd("p2g_mass_momentum_force", shape, where, accumulation_.traversal(pt), accumulation_.state(),
                 GridFields::mass,
                 MassAndMomentum{pt.mass, pt.velocity_x, pt.velocity_y}, GridFields::force_x,
                 InternalForce{pt.pressure, pt.artificial_viscosity, pt.mass, pt.density});
    p2g_end(accumulation_.state(), state);
  }
  {  // the sums on the nodes this slab shares with its neighbours
    auto t = timers.scope("halo_exchange");
    solver.halo_->sum_shared_nodes(state, 0, GridFields::num_state_columns);
  }
  {  // 4. boundary conditions on momentum and force
    auto t = timers.scope("boundary_conditions");
    solver.grid_boundaries_.apply_to_momentum_and_force(state);
  }
  const real_t mass_threshold = solver.node_mass_threshold_;
  const NodeFieldsView per_unit_mass = fields.per_unit_mass;
  {  // 5. momentum equation on the grid: (mv)' = mv + dt f; then V-bar = (mv)' / m and A = f / m
    auto t = timers.scope("grid_momentum_update");
    Kokkos::parallel_for(
        "grid_momentum_update", Kokkos::RangePolicy<ExecutionSpace>(0, grid.num_nodes()),
        KOKKOS_LAMBDA(const index_t i) {
          state(i, GridFields::momentum_x) += dt * state(i, GridFields::force_x);
          state(i, GridFields::momentum_y) += dt * state(i, GridFields::force_y);
          const real_t inv_m = per_unit_node_mass(state(i, GridFields::mass), mass_threshold);
          per_unit_mass(i, GridFields::velocity_x) = state(i, GridFields::momentum_x) * inv_m;
          per_unit_mass(i, GridFields::velocity_y) = state(i, GridFields::momentum_y) * inv_m;
          per_unit_mass(i, GridFields::acceleration_x) = state(i, GridFields::force_x) * inv_m;
          per_unit_mass(i, GridFields::acceleration_y) = state(i, GridFields::force_y) * inv_m;
        });
  }
  const StoreGridVelocityAndAccelerate accelerate{pt.grid_velocity_x, pt.grid_velocity_y, pt.velocity_x,
                                                  pt.velocity_y, dt};
  if (cfg.numerics.fused_kernels) {  // 6-8 in one pass
    auto t = timers.scope("g2p_p2g_velocity_momentum");
    p2g_begin(accumulation_.remap(), remap);
    g2p_then_p2g("g2p_p2g_velocity_momentum", shape, where, accumulation_.traversal(pt),
                 NodeColumns<4>{per_unit_mass, GridFields::velocity_x}, AccelerateThenCarryMomentum{accelerate, pt.mass},
                 accumulation_.remap(), GridFields::remap_momentum_x);
    p2g_end(accumulation_.remap(), remap);
  } else {
    {  // 6-7. G2P of velocity (V-bar) and acceleration; V' = V + dt A
      auto t = timers.scope("g2p_velocity_acceleration");
      g2p("g2p_velocity_acceleration", shape, where, n, NodeColumns<4>{per_unit_mass, GridFields::velocity_x},
          accelerate);
    }
    {  // 8. momentum P2G with the updated particle velocity
      auto t = timers.scope("p2g_momentum_remap");
      p2g_begin(accumulation_.remap(), remap);
      p2g("p2g_momentum_remap", shape, where, accumulation_.traversal(pt), accumulation_.remap(),
          GridFields::remap_momentum_x, Momentum{pt.mass, pt.velocity_x, pt.velocity_y});
      p2g_end(accumulation_.remap(), remap);
    }
  }
  {
    auto t = timers.scope("halo_exchange");
    solver.halo_->sum_shared_nodes(remap, 0, GridFields::num_remap_columns);
  }
  {  // 9. boundary conditions on the remapped momentum
    auto t = timers.scope("boundary_conditions");
    solver.grid_boundaries_.apply_to_momentum(remap, GridFields::remap_momentum_x, state);
  }
  {  // the remapped node velocity, for step 10
    auto t = timers.scope("grid_remap_velocity");
    Kokkos::parallel_for(
        "grid_remap_velocity", Kokkos::RangePolicy<ExecutionSpace>(0, grid.num_nodes()),
        KOKKOS_LAMBDA(const index_t i) {
          const real_t inv_m = per_unit_node_mass(state(i, GridFields::mass), mass_threshold);
          per_unit_mass(i, GridFields::remap_velocity_x) = remap(i, GridFields::remap_momentum_x) * inv_m;
          per_unit_mass(i, GridFields::remap_velocity_y) = remap(i, GridFields::remap_momentum_y) * inv_m;
        });
  }
  {  // 10. G2PD velocity gradient; density, energy, pressure update
    auto t = timers.scope("g2pd_particle_update");
    g2pd("g2pd_particle_update", shape, where, n,
         NodeColumns<2>{per_unit_mass, GridFields::remap_velocity_x},
         UpdateThermodynamics{pt.density, pt.specific_energy, pt.pressure, pt.artificial_viscosity,
                              pt.domain_stretch_x, pt.domain_stretch_y, dt,
                              cfg.physics.gamma, slab.cell_size(), cfg.physics.viscosity_quadratic,
                              cfg.physics.viscosity_linear});
  }
  {  // 11. the postponed particle move with V-bar; walls, recycling and obstacles on the particles
    auto t = timers.scope("particle_move");
    solver.particle_boundaries_.prepare_step(dt, solver.step_count_ + 1);
    const ParticleBoundaries boundaries = solver.particle_boundaries_;
    const ParticleState particles = pt;
    Kokkos::parallel_for(
        "particle_move", Kokkos::RangePolicy<ExecutionSpace>(0, n),
        KOKKOS_LAMBDA(const index_t p) { boundaries.move(p, dt, particles); });
  }
}

namespace {

bool use_duplicated(P2GStrategy strategy) {
  if (strategy == P2GStrategy::duplicated) return true;
  if (strategy == P2GStrategy::atomic) return false;
  // Kokkos' own rule: duplicated copies where the grid lives in host memory (few threads, cheap
  // copies), atomics on GPUs (thousands of threads, copies unaffordable).
  return std::is_same<MemorySpace, Kokkos::HostSpace>::value;
}

}  // namespace

template <class Accumulation>
std::unique_ptr<Solver::Stepper> Solver::make_stepper() const {
  const GridGeometry& geo = slab_.geometry;
  if (config_.numerics.shape_function == ShapeFunction::gimp) {
    // Each particle's initial domain is its share of the cell, ppc_x x ppc_y per cell.
    const GimpShape shape{geo, geo.spacing_x / (2 * config_.particles.per_cell_x),
                          geo.spacing_y / (2 * config_.particles.per_cell_y), particles_.domain_stretch_x,
                          particles_.domain_stretch_y};
    return std::make_unique<ScatterStepper<Accumulation, GimpShape>>(grid_fields_, shape);
  }
  return std::make_unique<ScatterStepper<Accumulation, LinearShape>>(grid_fields_, LinearShape{geo});
}

namespace {

// Sum of the first n values, in index order on the host: the same for any thread count (a
// parallel reduction's order depends on it), once at start-up.
double sum_in_order(const RealView& values, index_t n) {
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), values);
  double sum = 0;
  for (index_t k = 0; k < n; ++k) sum += host(k);
  return sum;
}

// The decomposition a lone slab stands for: itself, along x.
SlabDecomposition single_slab(const GridSlab& slab) {
  SlabDecomposition d;
  d.axis = 0;
  d.cell_begin = {0, slab.global_cells_x};
  return d;
}

}  // namespace

Solver::Solver(const CaseConfig& config, const GridSlab& slab, ParticleState particles)
    : config_(config),
      context_(),
      decomposition_(single_slab(slab)),
      slab_(slab),
      particles_(std::move(particles)) {
  if (context_.distributed()) context_ = ParallelContext::self();
  build_slab_state();
  const real_t total_mass = static_cast<real_t>(sum_in_order(particles_.mass, particles_.count));
  // A millionth of the mean particle mass: far below any node a particle really touches.
  node_mass_threshold_ = particles_.count > 0 ? real_t(1e-6) * total_mass / particles_.count : real_t(0);
}

Solver::Solver(const CaseConfig& config, const ParallelContext& context, const SlabDecomposition& decomposition,
               ParticleState particles)
    : config_(config),
      context_(context),
      decomposition_(decomposition),
      slab_(make_grid_slab(config.domain, decomposition.axis, decomposition.begin(context.rank()),
                           decomposition.end(context.rank()))),
      particles_(std::move(particles)) {
  build_slab_state();
  double mass_and_count[2] = {sum_in_order(particles_.mass, particles_.count),
                              double(particles_.count)};
  context_.sum_in_place(mass_and_count, 2);
  node_mass_threshold_ = mass_and_count[1] > 0 ? real_t(1e-6 * mass_and_count[0] / mass_and_count[1]) : real_t(0);
  // Particles read from a checkpoint written on another rank count arrive anywhere.
  migration_.migrate(particles_, slab_, decomposition_, context_);
  update_cell_map(slab_.geometry, particles_);
}

void Solver::build_slab_state() {
  grid_fields_ = GridFields(slab_.geometry);
  obstacle_grid_ = make_obstacle_grid(config_.obstacles, slab_);
  grid_boundaries_ = GridBoundaryConditions(config_, slab_, obstacle_grid_);
  particle_boundaries_ = ParticleBoundaries(config_, slab_, obstacle_grid_);
  halo_ = std::make_unique<HaloExchange>(slab_, decomposition_, context_, int(GridFields::num_state_columns));
  if (config_.numerics.p2g == P2GStrategy::sorted)
    stepper_ = make_stepper<ColouredAccumulation>();
  else if (use_duplicated(config_.numerics.p2g))
    stepper_ = make_stepper<ScatterAccumulation<Kokkos::Experimental::ScatterDuplicated>>();
  else
    stepper_ = make_stepper<ScatterAccumulation<Kokkos::Experimental::ScatterNonDuplicated>>();
}

Solver::~Solver() = default;

P2GStrategy Solver::p2g_strategy() const { return stepper_->strategy(); }

Solver::MemoryUse Solver::memory_use() const {
  MemoryUse use;
  particles_.for_each_field([&](const auto& field) {
    use.particle_bytes += field.span() * sizeof(typename std::decay_t<decltype(field)>::value_type);
  });
  use.grid_bytes = grid_fields_.bytes();
  use.scatter_copy_bytes = stepper_->scatter_copy_bytes();
  return use;
}

real_t Solver::stable_time_step() {
  auto t = timers_.scope("time_step");
  const auto vx = particles_.velocity_x, vy = particles_.velocity_y, p = particles_.pressure,
             rho = particles_.density;
  const real_t gamma = config_.physics.gamma;
  constexpr real_t invalid = std::numeric_limits<real_t>::max();  // no valid signal speed is this large
  const real_t max_speed = max_over_particles(
      "max_signal_speed", particles_.count, KOKKOS_LAMBDA(const index_t k) {
        const real_t speed = signal_speed(vx(k), vy(k), sound_speed(gamma, p(k), rho(k)));
        return is_valid_gas_state(rho(k), p(k), speed) ? speed : invalid;
      });
  const bool local_invalid = !(max_speed < invalid);
  const real_t global_max_speed = static_cast<real_t>(context_.max(local_invalid ? double(invalid) : double(max_speed)));
  if (!(global_max_speed < invalid)) report_invalid_particle(local_invalid);
  const real_t h = slab_.cell_size();
  // A gas at rest with zero pressure has no signal speed; any step is then stable.
  return global_max_speed > 0 ? config_.time.cfl * h / global_max_speed : config_.time.end_time;
}

void Solver::report_invalid_particle(bool local_invalid) const {
  // Every rank stops with the same message: that of the lowest rank holding a bad particle.
  const int reporting_rank = static_cast<int>(context_.min(local_invalid ? context_.rank() : context_.size()));
  std::string message;
  double where[3] = {0, 0, 0};  // id, x, y
  if (context_.rank() == reporting_rank) {
    try {
      describe_invalid_particle();
    } catch (const InvalidStateError& e) {
      message = e.what();
      where[0] = double(e.particle_id), where[1] = e.position_x, where[2] = e.position_y;
    }
  }
  context_.broadcast(message, reporting_rank);
  context_.broadcast(where, 3, reporting_rank);
  throw InvalidStateError(message, step_count_, static_cast<particle_id_t>(where[0]), real_t(where[1]), real_t(where[2]));
}

void Solver::describe_invalid_particle() const {
  const auto x = particles_.position_x, y = particles_.position_y, vx = particles_.velocity_x,
             vy = particles_.velocity_y, p = particles_.pressure, rho = particles_.density;
  const real_t gamma = config_.physics.gamma;
  index_t first = particles_.count;
  Kokkos::parallel_reduce(
      "find_invalid_particle", Kokkos::RangePolicy<ExecutionSpace>(0, particles_.count),
      KOKKOS_LAMBDA(const index_t k, index_t& smallest) {
        const real_t speed = signal_speed(vx(k), vy(k), sound_speed(gamma, p(k), rho(k)));
        const bool valid = is_valid_gas_state(rho(k), p(k), speed) && x(k) == x(k) && y(k) == y(k);
        if (!valid && k < smallest) smallest = k;
      },
      Kokkos::Min<index_t>(first));
  auto value_at = [&](const auto& view) {
    auto one = Kokkos::subview(view, std::make_pair(first, first + 1));
    auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), one);
    return host(0);
  };
  const particle_id_t id = value_at(particles_.id);
  const real_t px = value_at(x), py = value_at(y);
  std::ostringstream msg;
  msg << "invalid state after step " << step_count_ << ": particle " << id << " at (" << px << ", " << py
      << ") has density " << value_at(rho) << ", pressure " << value_at(p) << ", velocity (" << value_at(vx)
      << ", " << value_at(vy) << ")";
  throw InvalidStateError(msg.str(), step_count_, id, px, py);
}

void Solver::advance(real_t dt) {
  stepper_->advance(*this, dt);
  {  // particles that left the slab go to their new owners
    auto t = timers_.scope("migration");
    migration_.migrate(particles_, slab_, decomposition_, context_);
  }
  {  // cell map update (step x)
    auto t = timers_.scope("cell_map");
    update_cell_map(slab_.geometry, particles_);
  }
  ++step_count_;
  const int interval = config_.numerics.reorder_interval;
  if (interval > 0 && step_count_ % interval == 0) {  // 12. optional reordering
    auto t = timers_.scope("reorder");
    // Grouped by cell, in index order within a cell: the same order on any thread count.
    CellOrder order;
    order.build(particles_.cell, particles_.count, slab_.geometry.num_cells());
    particles_.for_each_field([&](const auto& field) { order.apply(field); });
  }
  const int balance_interval = config_.decomposition.balance_interval;
  if (context_.distributed() && balance_interval > 0 && step_count_ % balance_interval == 0) {
    auto t = timers_.scope("load_balance");
    balance_load();
  }
}

bool Solver::balance_load() {
  if (!context_.distributed()) return false;
  // Particles per global cell column (row for a y decomposition), from the cell map.
  const int axis = decomposition_.axis;
  const GridGeometry geo = slab_.geometry;
  const index_t columns = decomposition_.cells_along_axis();
  const index_t offset = axis == 0 ? slab_.node_offset_x : slab_.node_offset_y;
  const index_t local_columns = axis == 0 ? geo.cells_x() : geo.cells_y();
  Kokkos::View<long long*, Kokkos::LayoutLeft, DeviceType> local_counts("particles_per_column", local_columns);
  {
    Kokkos::Experimental::ScatterView<long long*, Kokkos::LayoutLeft, DeviceType> scatter(local_counts);
    const IndexView cell = particles_.cell;
    Kokkos::parallel_for(
        "particles_per_column", Kokkos::RangePolicy<ExecutionSpace>(0, particles_.count),
        KOKKOS_LAMBDA(const index_t p) {
          auto access = scatter.access();
          access(axis == 0 ? cell(p) % geo.cells_x() : cell(p) / geo.cells_x()) += 1;
        });
    Kokkos::Experimental::contribute(local_counts, scatter);
  }
  auto local_host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), local_counts);
  std::vector<long long> per_column(columns, 0);
  for (index_t c = 0; c < local_columns; ++c)
    if (c + offset >= 0 && c + offset < columns) per_column[c + offset] += local_host(c);
  context_.sum_in_place(per_column.data(), static_cast<int>(columns));

  auto per_rank = [&](const SlabDecomposition& d) {
    std::vector<long long> counts(d.num_ranks(), 0);
    for (int r = 0; r < d.num_ranks(); ++r)
      for (index_t c = d.begin(r); c < d.end(r); ++c) counts[r] += per_column[c];
    return counts;
  };
  const SlabDecomposition balanced = SlabDecomposition::balanced(axis, per_column, context_.size());
  const double before = imbalance(per_rank(decomposition_)), after = imbalance(per_rank(balanced));
  // Moving the slabs costs a migration and a rebuild of the grid: only for a real gain.
  if (balanced == decomposition_ || after > before - 0.01) return false;

  const GridSlab old_slab = slab_;
  decomposition_ = balanced;
  slab_ = make_grid_slab(config_.domain, axis, decomposition_.begin(context_.rank()),
                         decomposition_.end(context_.rank()));
  migration_.migrate(particles_, old_slab, decomposition_, context_);
  build_slab_state();
  update_cell_map(slab_.geometry, particles_);
  balance_reports_.push_back({step_count_, before, after, decomposition_});
  return true;
}

void Solver::project_to_grid() {
  // Untimed here: it is part of whatever phase asks for it (output).
  stepper_->project_mass_and_momentum(*this);
}

double Solver::step_towards(double t, double target) {
  const double dt = stable_time_step();
  // Round-off in t must not leave a sliver of a step before the target.
  const bool reaches_target = t + dt >= target - 1e-12 * target;
  advance(static_cast<real_t>(reaches_target ? target - t : dt));
  return reaches_target ? target : t + dt;
}

}  // namespace mpmflow
