#include "mpm_step.hpp"

#include "grid_phases.hpp"

namespace mpmflow {

// Algorithm 1, numbered as the paper numbers its steps. Each phase is timed and is a profiling
// region (phase_timers.hpp); the kernels are in transfers.cpp and kernels/, the node-by-node
// phases in grid_phases.cpp, the boundary conditions in boundary_conditions.cpp.
void project_particles_to_grid(const StepState& s) {
  PhaseTimers& timers = s.timers;
  const SlabState& slab = s.slab;
  const GridFields& grid = s.slab.fields();
  {  // 2. grid reset
    auto t = timers.scope(Phase::grid_reset);
    reset_grid(grid);
  }
  {  // 3. m = P2G(M), mv = P2G(M V), f = P2GD((P + Q) M / rho) (and P2G(P M / rho), P2G(M / rho))
    auto t = timers.scope(Phase::p2g_mass_momentum_force);
    s.transfers.p2g_mass_momentum_force(s.particles);
  }
  {  // ... summed over the slabs sharing a node
    auto t = timers.scope(Phase::halo_exchange);
    slab.halo().sum_shared_nodes(grid.state, 0, GridFields::num_state_columns);
  }
}

void finish_step(const StepState& s, const StepSettings& settings, real_t dt, long step) {
  PhaseTimers& timers = s.timers;
  const SlabState& slab = s.slab;
  const GridFields& grid = s.slab.fields();
  const ParticleState& particles = s.particles;
  TransferKernels& transfers = s.transfers;
  const real_t mass_threshold = settings.node_mass_threshold;
  const bool energy_budget = settings.thermodynamics.energy_consistent;
  {  // 4. boundary conditions on mv and f; obstacles (eqs. 21-22, the whole normal component)
    auto t = timers.scope(Phase::boundary_conditions);
    if (energy_budget) keep_momentum_and_force_before_conditions(grid);
    const GridBoundaryConditions& conditions = slab.grid_boundaries();
    // The particles' cover of the crossed sides' nodes and of the obstacles' surface bands, in one
    // pass over the particles; then summed over the ranks and the slabs (on every slab where the
    // case has obstacles: that sum is collective).
    const bool sides = conditions.pressure_side_nodes().any_crossed, obstacles = conditions.has_obstacles();
    if (sides) conditions.clear_pressure_side_gradients();
    if (obstacles) conditions.clear_obstacle_pressure_gradients();
    if (sides || obstacles) transfers.add_boundary_volume_gradients(particles, conditions.volume_gradients());
    if (sides) conditions.sum_pressure_side_gradients(slab.context());
    // (The acceleration columns as buffer: step 5 writes them next.)
    if (obstacles) conditions.sum_obstacle_pressure_gradients(slab.halo(), grid.per_unit_mass);
    conditions.apply_to_momentum_and_force(grid.state, &s.obstacle_forces);
  }
  {  // 5. (mv)' = mv + dt f; V-bar = (mv)' / m and A = f / m on the nodes; the momentum columns
     // cleared for the remap of step 8
    auto t = timers.scope(Phase::grid_momentum_update);
    update_grid_momentum(grid, dt, mass_threshold);
  }
  if (settings.fused_kernels) {  // 6.-8. in one pass over the particles (V-bar: see 11)
    auto t = timers.scope(Phase::g2p_p2g_velocity_momentum);
    transfers.g2p_p2g_velocity_momentum(particles, dt);
  } else {
    {  // 6. A = G2P(f / m) (V-bar = G2P(mv / m): see 11); 7. V' = V + dt A
      auto t = timers.scope(Phase::g2p_velocity_acceleration);
      transfers.g2p_velocity_acceleration(particles, dt);
    }
    {  // 8. mv = P2G(M V')
      auto t = timers.scope(Phase::p2g_momentum_remap);
      transfers.p2g_momentum_remap(particles);
    }
  }
  {  // ... summed over the slabs sharing a node
    auto t = timers.scope(Phase::halo_exchange);
    slab.halo().sum_shared_nodes(grid.state, GridFields::momentum_x, 2);
  }
  {  // 9. boundary conditions on mv
    auto t = timers.scope(Phase::boundary_conditions);
    if (energy_budget) keep_remap_before_conditions(grid);
    slab.grid_boundaries().apply_to_momentum(grid.state, GridFields::momentum_x, grid.state);
  }
  {  // ... and mv / m on the nodes, for step 10, the volume fraction phi = sum V / gas volume and
     // the mean pressure sum P V / sum V
    auto t = timers.scope(Phase::grid_remap_velocity);
    compute_remap_velocity(grid, mass_threshold, dt, settings.thermodynamics.energy_consistent);
    if (settings.thermodynamics.volume_correction)
      compute_volume_fraction(grid, slab.obstacles().node_gas_volume, slab.slab().cell_area(),
                              slab.grid_boundaries().pressure_side_nodes().node_entry);
  }
  double work_of_conditions = 0;
  if (energy_budget) {
    auto t = timers.scope(Phase::boundary_conditions);
    work_of_conditions = boundary_work(grid, dt, mass_threshold);
  }
  {  // 10. grad V = G2PD(mv / m); E', rho' (and Q) of the particles; 11. X' = X + dt V-bar, with
     // V-bar = G2P(mv' / m) at the same stencil (6. takes only A)
    auto t = timers.scope(Phase::g2pd_particle_update);
    transfers.g2pd_particle_update(particles, settings.thermodynamics, dt);
  }
  {  // 11. walls, open sides and obstacles; the cell map (unless the relaxation's pass makes it)
    auto t = timers.scope(Phase::particle_move);
    const double stopped = apply_particle_rules(slab.particle_boundaries(), particles, dt, &s.obstacle_forces);
    s.open_sides.add_boundary_energy(work_of_conditions, stopped);
    if (!transfers.relaxes_pressure()) locate_particles(slab.particle_boundaries(), particles);
  }
  if (transfers.relaxes_pressure()) {  // each cell's pressures evened out at the acoustic rate; the cell map
    auto t = timers.scope(Phase::pressure_relaxation);
    transfers.relax_pressures_and_locate(particles, settings.thermodynamics, dt, slab.particle_boundaries().locator());
  }
  {  // particles that left through open sides removed (or recycled), the free stream's entered
    auto t = timers.scope(Phase::open_sides);
    s.open_sides.exchange(s.particles, slab, dt, step);
  }
  if (s.splitting.enabled()) {  // particles whose volume has doubled split in two
    auto t = timers.scope(Phase::splitting);
    s.splitting.split(s.particles, slab.particle_boundaries(), slab.context());
  }
  {  // particles that left the slab go to the ranks owning their cells
    auto t = timers.scope(Phase::migration);
    s.migration.migrate(s.particles, slab.slab(), slab.decomposition(), slab.context());
  }
  // (Each particle's cell, which the next step's kernels start from, comes from the particle
  // boundaries, or from what added the particle: the open sides, splitting, migration.)
  // Tiny split particles of a cell merged in pairs (needs the cells); none before the run's first
  // split (a count over all ranks: every rank skips alike).
  if (s.merging.enabled() && s.splitting.splits() > 0) {
    auto t = timers.scope(Phase::merging);
    s.merging.merge(s.particles, slab.particle_boundaries());
  }
  if (settings.reorder_interval > 0 && step % settings.reorder_interval == 0) {  // 12. optional reordering
    auto t = timers.scope(Phase::reorder);
    reorder_particles_by_cell(s.particles, slab.geometry().num_cells(), s.reorder_order);
  }
}

}  // namespace mpmflow
