#pragma once
// Conservation diagnostics over the particles, computed with Kokkos Kernels' BLAS-1 routines.
#include <string>
#include <utility>
#include <vector>

#include "case_config.hpp"
#include "particles.hpp"

namespace mpmflow {

struct ConservationTotals {
  double mass = 0;
  double momentum_x = 0;
  double momentum_y = 0;
  double kinetic_energy = 0;
  double internal_energy = 0;
  double total_energy() const { return kinetic_energy + internal_energy; }
  ConservationTotals& operator+=(const ConservationTotals& o) {
    mass += o.mass, momentum_x += o.momentum_x, momentum_y += o.momentum_y;
    kinetic_energy += o.kinetic_energy, internal_energy += o.internal_energy;
    return *this;
  }

  // Calls f(name, value) for every total: the one list for the sums over ranks, diagnostics.csv,
  // the snapshots' and the checkpoints' attributes.
  template <class F>
  void for_each_total(F&& f) {
    visit(*this, f);
  }
  template <class F>
  void for_each_total(F&& f) const {
    visit(*this, f);
  }

 private:
  template <class Self, class F>
  static void visit(Self& self, F& f) {
    f("mass", self.mass), f("momentum_x", self.momentum_x), f("momentum_y", self.momentum_y);
    f("kinetic_energy", self.kinetic_energy), f("internal_energy", self.internal_energy);
  }
};

// What the boundaries did so far (this rank's share, summed over the ranks for output): the
// conservation totals of the particles that entered and of those that left through the open
// sides, and the energy the boundaries gave the gas. With them the balances
//   mass(t) = mass(0) + mass_in - mass_out,
//   total_energy(t) = total_energy(0) + (kinetic + internal energy)_in - (...)_out
//                     + energy_boundary_work - kinetic_energy_stopped
// close to round-off (the energy balance with numerics/energy_consistent).
struct BoundaryFluxes {
  ConservationTotals entered;
  ConservationTotals left;
  // The work of the grid's boundary conditions (inflow velocity, outside pressure and inertia on
  // open sides, the normal component removed at obstacles; none at slip walls): what the forces
  // the particles feel do beyond the work of their own pressure (grid_phases.hpp, boundary_work).
  double boundary_work = 0;
  // The kinetic energy of the velocity that particles crossing a slip wall or entering an
  // obstacle lose in the move (boundary_conditions.hpp).
  double kinetic_energy_stopped = 0;

  // Calls f(name, value) for every flux: "<total>_in" and "<total>_out" for every conservation
  // total: the one list for the sums over ranks, diagnostics.csv, snapshots and checkpoints.
  template <class F>
  void for_each_flux(F&& f) {
    visit(*this, f);
  }
  template <class F>
  void for_each_flux(F&& f) const {
    visit(*this, f);
  }

 private:
  template <class Self, class F>
  static void visit(Self& self, F& f) {
    self.entered.for_each_total([&](const char* name, auto&& value) { f(std::string(name) + "_in", value); });
    self.left.for_each_total([&](const char* name, auto&& value) { f(std::string(name) + "_out", value); });
    f(std::string("energy_boundary_work"), self.boundary_work);
    f(std::string("kinetic_energy_stopped"), self.kinetic_energy_stopped);
  }
};

// The conservation totals of this rank's particles (BLAS-1 sums, kernels/blas1.hpp). Taken at the
// start, at each snapshot and at the end: its products M Vx and M Vy take a particle field's room
// only while it runs (kept from call to call, they had held 8 B a particle for the whole run).
ConservationTotals particle_totals(const ParticleState& particles);

// Named columns of diagnostics.csv and the snapshots' /diagnostics beyond the totals and fluxes.
using DiagnosticColumns = std::vector<std::pair<std::string, double>>;

// The force on each obstacle k of the case (mean_forces: x and y of each, in case order) as
// columns obstacle<k>_force_x, obstacle<k>_force_y, and where the free stream moves,
// obstacle<k>_drag_coefficient and obstacle<k>_lift_coefficient: the force along the free stream
// and along it turned 90 degrees counter-clockwise, over q_inf L with q_inf = rho_inf |v_inf|^2 / 2
// and L the obstacle's reference length (per unit depth: the domain is 2D).
DiagnosticColumns obstacle_force_columns(const CaseConfig& config, const std::vector<double>& mean_forces);

}  // namespace mpmflow
