#pragma once
// Material points: structure-of-arrays Views, one per field.
#include "case_config.hpp"
#include "grid.hpp"
#include "kernels/transfer_kernels.hpp"

namespace mpmflow {

struct ParticleState {
  index_t count = 0;
  RealView position_x, position_y;
  RealView velocity_x, velocity_y;
  // The grid velocity interpolated at the particle (V-bar of Algorithm 1, step 6), which moves it.
  RealView grid_velocity_x, grid_velocity_y;
  RealView mass;
  RealView density;
  RealView specific_energy;       // internal energy per unit mass, e
  RealView pressure;
  RealView artificial_viscosity;  // q of the last update, used by the next force P2GD
  // Current / initial length of the particle's domain along x and y (GIMP particle size).
  RealView domain_stretch_x, domain_stretch_y;
  IndexView cell;                 // local cell containing the particle
  ParticleIdView id;              // stable identity, independent of ordering and of rank

  explicit ParticleState(index_t n = 0);

  // Calls f(view) for every per-particle View: the one list of the fields, for everything that
  // must treat all of them alike (reordering, migration, memory accounting).
  template <class F>
  void for_each_field(F&& f) const {
    for (const RealView& v : {position_x, position_y, velocity_x, velocity_y, grid_velocity_x, grid_velocity_y,
                              mass, density, specific_energy, pressure, artificial_viscosity, domain_stretch_x,
                              domain_stretch_y})
      f(v);
    f(cell);
    f(id);
  }

  ParticleLocations locations() const { return {position_x, position_y, cell}; }
};

// Particles of the initial state on the slab's owned cells, placed as the case asks; ids are
// global (cell-major), so they do not depend on how the grid is split.
ParticleState create_initial_particles(const CaseConfig& config, const GridSlab& slab);

// The initial gas state at (x, y): the background, overridden by the last region containing it.
GasState initial_state_at(const InitialStateConfig& initial, real_t x, real_t y);

// Recomputes every particle's cell from its position (Algorithm 1, step x).
void update_cell_map(const GridGeometry& geometry, const ParticleState& particles);

}  // namespace mpmflow
