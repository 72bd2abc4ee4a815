#include "solver.hpp"

#include <algorithm>
#include <sstream>
#include <type_traits>

#include "gas_physics.hpp"
#include "grid_phases.hpp"

namespace mpmflow {
namespace {

// Sum of the first n values, in index order on the host: the same for any thread count (a
// parallel reduction's order depends on it), once at start-up.
double sum_in_order(const RealView& values, index_t n) {
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), values);
  double sum = 0;
  for (index_t k = 0; k < n; ++k) sum += host(k);
  return sum;
}

// Entry k of a device View, read on the host.
template <class ViewType>
typename ViewType::non_const_value_type value_at(const ViewType& view, index_t k) {
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), Kokkos::subview(view, std::make_pair(k, k + 1)));
  return host(0);
}

// Particle k's pressure, read on the host (for messages).
real_t pressure_at(const ParticleState& pt, index_t k, real_t gamma) {
  return perfect_gas_pressure(gamma, value_at(pt.density, k), value_at(pt.specific_energy, k));
}

// This slab's particles per global cell column along its axis (row for slabs along y), from the
// cell map; zero outside the slab.
std::vector<long long> particles_per_column(const ParticleState& particles, const GridSlab& slab) {
  const int axis = slab.axis;
  const IndexRange2D owned = slab.index_space(Ownership::owned, Entity::cell, Indexing::local);
  const index_t first = owned.begin(axis), columns = owned.end(axis) - first;
  const GridGeometry geometry = slab.geometry;
  Kokkos::View<long long*, Kokkos::LayoutLeft, DeviceType> counts("particles_per_column", columns);
  {
    Kokkos::Experimental::ScatterView<long long*, Kokkos::LayoutLeft, DeviceType> scatter(counts);
    const IndexView cell = particles.cell;
    Kokkos::parallel_for(
        "particles_per_column", Kokkos::RangePolicy<ExecutionSpace>(0, particles.count),
        KOKKOS_LAMBDA(const index_t p) {
          const index_t column = (axis == 0 ? geometry.cell_i_of(cell(p)) : geometry.cell_j_of(cell(p))) - first;
          if (column >= 0 && column < columns) scatter.access()(column) += 1;
        });
    Kokkos::Experimental::contribute(counts, scatter);
  }
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), counts);
  std::vector<long long> per_column(slab.global_cells(axis), 0);
  const index_t first_global = slab.index_space(Ownership::owned, Entity::cell, Indexing::global).begin(axis);
  for (index_t c = 0; c < columns; ++c) per_column[first_global + c] = host(c);
  return per_column;
}

}  // namespace

Solver::Solver(const CaseConfig& config, const GridSlab& slab, ParticleState particles)
    : Solver(config, std::make_unique<SlabState>(config, slab), std::move(particles)) {}

Solver::Solver(const CaseConfig& config, const ParallelContext& context, const SlabDecomposition& decomposition,
               ParticleState particles)
    : Solver(config, std::make_unique<SlabState>(config, context, decomposition), std::move(particles)) {}

Solver::Solver(const CaseConfig& config, std::unique_ptr<SlabState> slab_state, ParticleState particles)
    : config_(config),
      slab_(std::move(slab_state)),
      particles_(std::move(particles)),
      open_sides_(config, slab_->slab()),
      splitting_(config, slab_->slab()),
      merging_(config, slab_->geometry()),
      timers_(config.output.phase_timers) {
  transfers_ = make_transfer_kernels(config_, slab_->geometry(), slab_->fields());
  settings_.fused_kernels = config_.numerics.fused_kernels;
  settings_.reorder_interval = config_.numerics.reorder_interval;
  settings_.thermodynamics = thermodynamic_constants(config_, slab_->slab().cell_size());
  double mass_and_count[2] = {sum_in_order(particles_.mass, particles_.count), double(particles_.count)};
  context().sum_in_place(mass_and_count, 2);
  // A millionth of the mean particle mass: far below any node a particle really touches.
  settings_.node_mass_threshold =
      mass_and_count[1] > 0 ? real_t(1e-6 * mass_and_count[0] / mass_and_count[1]) : real_t(0);
  // Particles read from a checkpoint written on another rank count arrive anywhere.
  migration_.migrate(particles_, slab(), decomposition(), context());
  update_cell_map(slab().geometry, particles_);
}

Solver::~Solver() = default;

void Solver::build_slab(const SlabDecomposition& decomposition) {
  slab_ = std::make_unique<SlabState>(config_, context(), decomposition);
  transfers_ = make_transfer_kernels(config_, slab_->geometry(), slab_->fields());
  grid_holds_particles_ = false;  // new, empty node fields
}

Solver::MemoryUse Solver::memory_use() const {
  MemoryUse use;
  particles_.for_each_field([&](const auto& field) {
    use.particle_bytes += field.span() * sizeof(typename std::decay_t<decltype(field)>::value_type);
  });
  use.grid_bytes = slab_->fields().bytes();
  use.scatter_copy_bytes = transfers_->scratch_bytes();
  use.reorder_bytes = reorder_order_.bytes();
  return use;
}

StepState Solver::step_state() {
  return {*slab_, particles_, *transfers_, migration_, open_sides_, splitting_, merging_, timers_, step_forces_, reorder_order_};
}

void Solver::prepare_grid() {
  if (grid_holds_particles_) return;
  project_particles_to_grid(step_state());
  grid_holds_particles_ = true;
}

namespace {
// The signal speed |v| + c of the gas beyond the open sides, the free stream (0 without open
// sides): it enters at inflow and far-field sides and presses on outflow and far-field ones, so its
// waves cross the side nodes whatever the gas inside them. (Without it, a tunnel whose gas inside
// is slower than its free stream took steps too long for the nodes the free stream drives: a
// far-field side with the free stream entering at 2 into gas at rest (c = 1) stopped at the first
// step with a negative density.)
real_t open_side_signal_speed(const BoundaryConfig& boundaries, real_t gamma) {
  if (!boundaries.any_open() || !boundaries.has_free_stream) return 0;
  const GasState& gas = boundaries.free_stream;
  return signal_speed(gas.velocity_x, gas.velocity_y, sound_speed(gamma, gas.pressure, gas.density));
}
}  // namespace

real_t Solver::stable_time_step() { return stable_time_step_and_stop_request(0); }

real_t Solver::stable_time_step_and_stop_request(int local_request) {
  prepare_grid();
  auto t = timers_.scope(Phase::time_step);
  // The P2G checked every particle's state on its way (particles_in_doubt); a pass over them
  // decides only where it found some in doubt.
  const bool local_invalid =
      transfers_->particles_in_doubt() > 0 && count_invalid_gas_states(particles_, config_.physics.gamma) > 0;
  const real_t node_speed = max_node_signal_speed(slab_->fields(), config_.physics.gamma, settings_.node_mass_threshold);
  const real_t max_speed =
      local_invalid ? largest_real
                    : std::max(node_speed, open_side_signal_speed(config_.boundaries, config_.physics.gamma));
  // The ranks' largest signal speed and stop request, in one reduction.
  double largest[2] = {double(max_speed), double(local_request)};
  context().max_in_place(largest, 2);
  const real_t global_max_speed = static_cast<real_t>(largest[0]);
  stop_request_ = static_cast<int>(largest[1]);
  if (!(global_max_speed < largest_real)) {
    if (context().max(local_invalid ? 1.0 : 0.0) > 0) report_invalid_particle(local_invalid);
    // Valid particles whose node sums overflow.
    throw InvalidStateError("invalid state after step " + std::to_string(step_count_) +
                                ": a node's signal speed is not finite, though every particle's state is",
                            step_count_, -1, 0, 0);
  }
  // A gas at rest with zero pressure has no signal speed; any step is then stable.
  return global_max_speed > 0 ? config_.time.cfl * slab().cell_size() / global_max_speed : config_.time.end_time;
}

void Solver::report_invalid_particle(bool local_invalid) const {
  // Every rank stops with the same message: that of the lowest rank holding a bad particle.
  const ParallelContext& context = this->context();
  const int reporting_rank = static_cast<int>(context.min(local_invalid ? context.rank() : context.size()));
  std::string message;
  double where[3] = {0, 0, 0};  // id, x, y
  if (context.rank() == reporting_rank) {
    const ParticleState& pt = particles_;
    const index_t k = first_invalid_particle(pt, config_.physics.gamma);
    const particle_id_t id = value_at(pt.id, k);
    const real_t x = value_at(pt.position_x, k), y = value_at(pt.position_y, k);
    std::ostringstream msg;
    msg << "invalid state after step " << step_count_ << ": particle " << id << " at (" << x << ", " << y
        << ") has density " << value_at(pt.density, k) << ", pressure " << pressure_at(pt, k, config_.physics.gamma)
        << ", velocity (" << value_at(pt.velocity_x, k) << ", " << value_at(pt.velocity_y, k) << ")";
    message = msg.str();
    where[0] = double(id), where[1] = x, where[2] = y;
  }
  context.broadcast(message, reporting_rank);
  context.broadcast(where, 3, reporting_rank);
  throw InvalidStateError(message, step_count_, static_cast<particle_id_t>(where[0]), real_t(where[1]),
                          real_t(where[2]));
}

void Solver::advance(real_t dt) {
  particle_steps_ += particles_.count;
  prepare_grid();
  grid_holds_particles_ = false;  // the step moves the particles
  finish_step(step_state(), settings_, dt, step_count_ + 1);
  ++step_count_;
  if (!config_.obstacles.empty()) {
    // Summed over the ranks every step, so that every rank holds the same impulse (checkpoints
    // store it once).
    const size_t n = config_.obstacles.size();
    std::vector<double> forces(2 * n);
    for (size_t o = 0; o < n; ++o) forces[2 * o] = step_forces_.x[o], forces[2 * o + 1] = step_forces_.y[o];
    context().sum_in_place(forces.data(), static_cast<int>(forces.size()));
    if (obstacle_impulse_.empty()) obstacle_impulse_.assign(2 * n + 1, 0.0);
    obstacle_impulse_[0] += dt;
    for (size_t k = 0; k < 2 * n; ++k) obstacle_impulse_[k + 1] += forces[k] * dt;
  }
  const int interval = config_.decomposition.balance_interval;
  if (context().distributed() && interval > 0 && step_count_ % interval == 0) {
    auto t = timers_.scope(Phase::load_balance);
    balance_load();
  }
}

bool Solver::balance_load() {
  if (!context().distributed()) return false;
  std::vector<long long> per_column = particles_per_column(particles_, slab());
  context().sum_in_place(per_column.data(), static_cast<int>(per_column.size()));

  auto per_rank = [&](const SlabDecomposition& d) {
    std::vector<long long> counts(d.num_ranks(), 0);
    for (int r = 0; r < d.num_ranks(); ++r)
      for (index_t c = d.begin(r); c < d.end(r); ++c) counts[r] += per_column[c];
    return counts;
  };
  const SlabDecomposition balanced = SlabDecomposition::balanced(slab().axis, per_column, context().size());
  const double before = imbalance(per_rank(decomposition())), after = imbalance(per_rank(balanced));
  // Moving the slabs costs a migration and a rebuild of the grid: only for a real gain.
  if (balanced == decomposition() || after > before - 0.01) return false;

  const GridSlab old_slab = slab();
  build_slab(balanced);
  migration_.migrate(particles_, old_slab, decomposition(), context());
  update_cell_map(slab().geometry, particles_);
  balance_reports_.push_back({step_count_, before, after, decomposition()});
  return true;
}

NodeFieldsView Solver::grid_projection() const {
  NodeFieldsView projection("grid_projection", slab().geometry.num_nodes(), GridFields::num_projection_columns);
  transfers_->p2g_output_projection(particles_, projection);
  slab_->halo().sum_shared_nodes(projection, 0, GridFields::num_projection_columns);
  return projection;
}

std::vector<double> Solver::take_mean_obstacle_forces() {
  const size_t n = config_.obstacles.size();
  std::vector<double> mean(2 * n, 0.0);
  if (!obstacle_impulse_.empty() && obstacle_impulse_[0] > 0)
    for (size_t k = 0; k < 2 * n; ++k) mean[k] = obstacle_impulse_[k + 1] / obstacle_impulse_[0];
  obstacle_impulse_.assign(2 * n + 1, 0.0);
  return mean;
}

std::string Solver::describe_fastest_particle() const {
  const ParallelContext& context = this->context();
  const index_t k = fastest_particle(particles_, config_.physics.gamma);
  double speed = -1;
  if (k >= 0)
    speed = signal_speed(value_at(particles_.velocity_x, k), value_at(particles_.velocity_y, k),
                         perfect_gas_sound_speed(config_.physics.gamma, value_at(particles_.specific_energy, k)));
  const double fastest = context.max(speed);
  // The lowest rank holding a particle that fast describes it.
  const int reporting_rank = static_cast<int>(context.min(speed == fastest && k >= 0 ? context.rank() : context.size()));
  std::string message;
  if (context.rank() == reporting_rank) {
    std::ostringstream msg;
    msg << "particle " << value_at(particles_.id, k) << " at (" << value_at(particles_.position_x, k) << ", "
        << value_at(particles_.position_y, k) << "): |v| + c = " << speed << " (density "
        << value_at(particles_.density, k) << ", pressure " << pressure_at(particles_, k, config_.physics.gamma) << ")";
    message = msg.str();
  }
  if (reporting_rank < context.size()) context.broadcast(message, reporting_rank);
  return message;
}

double Solver::step_towards(double t, double target, int stop_request) {
  const double dt = stable_time_step_and_stop_request(stop_request);
  if (stop_request_ > 0) return t;
  last_stable_time_step_ = dt;
  // Round-off in t must not leave a sliver of a step before the target.
  const bool reaches_target = t + dt >= target - 1e-12 * target;
  advance(static_cast<real_t>(reaches_target ? target - t : dt));
  return reaches_target ? target : t + dt;
}

}  // namespace mpmflow
