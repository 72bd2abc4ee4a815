#pragma once
// The particle-grid transfers of one MPM step (Algorithm 1, steps 3, 6-8 and 10, and the
// projection for grid output), each one call of the generic kernels of kernels/ with the
// on-the-fly functors of the paper. Behind this interface they are specialised, once, on the
// shape function and on how P2G accumulates (ScatterView duplicated or atomic, or sorted and
// coloured); the time step (mpm_step.hpp) calls them without knowing which.
#include <memory>

#include "boundary_conditions.hpp"
#include "case_config.hpp"
#include "grid.hpp"
#include "particles.hpp"

namespace mpmflow {

// The constants of the particle update (step 10): perfect gas and artificial viscosity.
struct ThermodynamicConstants {
  real_t gamma = 0;
  real_t cell_size = 0;  // h of the artificial viscosity
  real_t viscosity_quadratic = 0;
  real_t viscosity_linear = 0;
  // numerics/energy_consistent: the work of the step's forces heats the particles, with the (P + Q)
  // the forces were made of (the step's velocity gradient is then that of the midpoint velocity,
  // compute_remap_velocity); the new Q only enters the next step's forces.
  bool energy_consistent = true;
  // numerics/volume_correction: each particle's density corrected towards the volume fraction of
  // the nodes around it (volume_corrected_density).
  bool volume_correction = true;
};

// The constants as a run takes them from the case, for cells of `cell_size`: the one place the
// solver and the tests make them. The volume correction does not act with cell-averaged strain
// (README, Numerics).
ThermodynamicConstants thermodynamic_constants(const CaseConfig& config, real_t cell_size);

// Bound to the grid fields of one slab (rebuilt with them).
class TransferKernels {
 public:
  virtual ~TransferKernels() = default;

  // 3. m = P2G(M), mv = P2G(M V), f = P2GD((P + Q) M / rho) into the state columns (zeroed), with
  // P2G(P M / rho) for the time step and P2G(M / rho) for the volume correction.
  // With numerics/cell_averaged_strain, P + Q is its volume-weighted mean over the particle's cell.
  // In the same pass, the particles whose state is in doubt (particles_in_doubt).
  virtual void p2g_mass_momentum_force(const ParticleState& particles) = 0;
  // The particles whose state the last p2g_mass_momentum_force found in doubt (not
  // surely_valid_gas_state): with none, every particle's state is valid, and the time step needs
  // no pass of its own to check them; otherwise count_invalid_gas_states decides.
  virtual index_t particles_in_doubt() const = 0;
  // 6.-8. in one pass: V' = V + dt G2P(f / m) from the per-unit-mass columns, then mv = P2G(M V')
  // into the state's momentum columns (zeroed). (In two where fuses_g2p_with_remap is false.)
  virtual void g2p_p2g_velocity_momentum(const ParticleState& particles, real_t dt) = 0;
  // Whether g2p_p2g_velocity_momentum is one pass: not with the sorted P2G of the GPU paths, whose
  // thread a block of nodes gathers from particles that a fused pass would be updating meanwhile
  // (walk_nodes_gathering): there it runs the two kernels below one after the other.
  virtual bool fuses_g2p_with_remap() const = 0;
  // 6.-7. alone: V'.
  virtual void g2p_velocity_acceleration(const ParticleState& particles, real_t dt) = 0;
  // 8. alone: mv = P2G(M V') into the state's momentum columns (zeroed).
  virtual void p2g_momentum_remap(const ParticleState& particles) = 0;
  // 10. grad V = G2PD(mv / m) from the remapped velocity columns; density, energy, artificial
  // viscosity and (GIMP) the particle domain's stretches; and, with V-bar = G2P(mv' / m) at the
  // same stencil, the move X' = X + dt V-bar (the walls, obstacles and sides come after). With
  // numerics/cell_averaged_strain, the volume-weighted mean divergence of the particle's cell
  // changes its density and energy, and that cell's mean P + Q of the force does the work. With
  // numerics/volume_correction, the density is corrected towards the nodes' volume fraction.
  virtual void g2pd_particle_update(const ParticleState& particles, const ThermodynamicConstants& constants,
                                    real_t dt) = 0;
  // Whether the case has numerics/pressure_relaxation: then relax_pressures_and_locate, after step
  // 11's particle rules (apply_particle_rules), takes the place of locate_particles.
  virtual bool relaxes_pressure() const = 0;
  // The particles of each cell (the cell of before the move, which the cell map still holds) go
  // towards its common pressure (the step's state columns are spent: they hold the cell sums);
  // the same pass over the particles then gives each its new cell (`locate`), one pass instead of
  // two. The particle rules do not change what the relaxation reads (mass, density, energy).
  virtual void relax_pressures_and_locate(const ParticleState& particles, const ThermodynamicConstants& constants,
                                          real_t dt, const ParticleLocator& locate) = 0;
  // m = P2G(M), mv = P2G(M V), and P2G(M rho), P2G(M P), P2G(M E) into `target`
  // (GridFields::ProjectionColumn, zeroed here): the particles' state on the grid, for output.
  // Writes no field of the step.
  virtual void p2g_output_projection(const ParticleState& particles, const NodeFieldsView& target) = 0;

  // Step 4's g_i = sum_p (M / rho) grad phi_i on the crossed pressure sides' nodes (on which the
  // gas outside acts) and on the obstacles' pressure nodes (BoundaryVolumeGradients, from
  // GridBoundaryConditions), added into their gradients in their integer units: one pass over the
  // particles' cells, the stencils only of the particles of the cells it marks.
  virtual void add_boundary_volume_gradients(const ParticleState& particles, const BoundaryVolumeGradients& sums) = 0;

  // The P2G accumulation in use ("automatic" resolved for this execution space).
  virtual P2GStrategy strategy() const = 0;
  // Bytes held besides the grid fields: duplicated ScatterView copies, or the cell order.
  virtual size_t scratch_bytes() const = 0;
};

// The particles' order that numerics/reorder_interval keeps, for the CPU walk's tiles.
ParticleOrder particle_order_of(const NumericsConfig& numerics);

// The transfers the case asks for (numerics/shape_function and numerics/p2g), on `fields` of a
// slab of `geometry`. A duplicated P2G gives `fields` a new state View (the first of its copies,
// zeroed): make the transfers before anything keeps a handle of the state.
std::unique_ptr<TransferKernels> make_transfer_kernels(const CaseConfig& config, const GridGeometry& geometry,
                                                       GridFields& fields);

}  // namespace mpmflow
