#pragma once
// Material points: structure-of-arrays Views, one per field.
#include "case_config.hpp"
#include "grid.hpp"
#include "kernels/transfer_kernels.hpp"

#include <type_traits>

namespace mpmflow {

// The cell of a particle that has left the domain through an open side, from the move until the
// open sides remove or recycle it.
enum ParticleCellMark : index_t { left_the_domain = -1 };

struct ParticleState {
  index_t count = 0;
  RealView position_x, position_y;
  RealView velocity_x, velocity_y;
  // (V-bar, the grid velocity that moves a particle, is not stored: the step's G2P-and-G2PD
  // interpolates it and advances the position, which apply_particle_boundaries then corrects.)
  RealView mass;
  RealView density;
  RealView specific_energy;       // internal energy per unit mass, e
  // (No pressure field: a perfect gas's is (gamma - 1) rho e, perfect_gas_pressure; one source of
  // truth, and 8 B per particle less.)
  RealView artificial_viscosity;  // q of the last update, used by the next force P2GD
  // Current / initial length of the particle's domain along x and y (GIMP particle size).
  RealView domain_stretch_x, domain_stretch_y;
  IndexView cell;                 // local cell containing the particle (or left_the_domain)
  ParticleIdView id;              // stable identity, independent of ordering and of rank

  explicit ParticleState(index_t n = 0);
  // Copies share the Views (as Views do). A move leaves its source empty: with Kokkos 3.4 a View's
  // move is a copy (impl/Kokkos_ViewTracker.hpp has no move constructor), so a defaulted move left
  // the source sharing every field, and whatever the source's owner kept alive stayed allocated
  // beside the Views' grown or reordered copies (`mpmflow run` kept the initial particles the whole
  // run: the cylinder's peak at 448 x 224 cells 210 MB instead of 129).
  ParticleState(const ParticleState&) = default;
  ParticleState& operator=(const ParticleState&) = default;
  ParticleState(ParticleState&& other) noexcept : ParticleState(static_cast<const ParticleState&>(other)) {
    other.release();
  }
  ParticleState& operator=(ParticleState&& other) noexcept {
    if (this != &other) {
      *this = static_cast<const ParticleState&>(other);
      other.release();
    }
    return *this;
  }

  // Calls f(view) for every per-particle View: the one list of the fields, for everything that
  // must treat all of them alike (reordering, migration, checkpoints, memory accounting). The
  // non-const form may reallocate the Views (capacity growth, reordering).
  template <class F>
  void for_each_field(F&& f) const {
    visit_fields(*this, f);
  }
  template <class F>
  void for_each_field_mutable(F&& f) {
    visit_fields(*this, f);
  }

  // Particles the Views can hold; `count` of them are in use. The count changes (migration, open
  // sides); the Views never shrink and grow geometrically, so that they rarely reallocate.
  index_t capacity() const { return static_cast<index_t>(position_x.extent(0)); }
  // Grows every View to hold at least `n` particles, keeping the first `count` (the rest unset).
  void reserve(index_t n);
  // Makes room for `n` particles: when the capacity is short, grows it to n plus an eighth of it
  // (amortised O(1) copies per particle added, at most 12.5 % spare: memory per particle matters
  // more here than the rare copy).
  void grow_to_hold(index_t n) {
    if (n > capacity()) reserve(n + n / 8);
  }

  ParticleLocations locations() const { return {position_x, position_y, cell}; }

  // No particles and no Views: each field let go of (a copy elsewhere keeps its data).
  void release() {
    count = 0;
    for_each_field_mutable([](auto& field) { field = std::decay_t<decltype(field)>(); });
  }

 private:
  template <class Self, class F>
  static void visit_fields(Self& self, F& f) {
    f(self.position_x), f(self.position_y), f(self.velocity_x), f(self.velocity_y);
    f(self.mass), f(self.density);
    f(self.specific_energy), f(self.artificial_viscosity);
    f(self.domain_stretch_x), f(self.domain_stretch_y), f(self.cell), f(self.id);
  }
};

// Every particle field, by its type, gathered from ParticleState::for_each_field (the one list of
// the fields): so that one kernel moves particles whole, where a kernel a field made a dozen
// launches (a GPU pays microseconds a launch however few particles move; splitting and the hole
// filling of the open sides run every step).
struct WholeParticles {
  static constexpr int max_fields_of_a_type = 16;
  Kokkos::Array<RealView, max_fields_of_a_type> reals;
  Kokkos::Array<IndexView, max_fields_of_a_type> indices;
  Kokkos::Array<ParticleIdView, max_fields_of_a_type> ids;
  int num_reals = 0, num_indices = 0, num_ids = 0;

  explicit WholeParticles(const ParticleState& particles);
  // Particle `to` becomes a copy of particle `from`.
  KOKKOS_INLINE_FUNCTION void copy(index_t to, index_t from) const {
    for (int f = 0; f < num_reals; ++f) reals[f](to) = reals[f](from);
    for (int f = 0; f < num_indices; ++f) indices[f](to) = indices[f](from);
    for (int f = 0; f < num_ids; ++f) ids[f](to) = ids[f](from);
  }
};

// Particle destinations(k) (first + k where `destinations` is empty) becomes a copy of particle
// sources(k), for k < n, every field, in one launch. No destination may be a source.
void copy_particles(const char* label, const ParticleState& particles, const IndexView& destinations, index_t first,
                    const IndexView& sources, index_t n);

// Particles of the initial state on the slab's owned cells, placed as the case asks; ids are
// global (cell-major), so they do not depend on how the grid is split.
ParticleState create_initial_particles(const CaseConfig& config, const GridSlab& slab);

// The initial gas state at (x, y): the background, overridden by the last region containing it.
GasState initial_state_at(const InitialStateConfig& initial, real_t x, real_t y);

// Recomputes the cell of every particle from index `first` on from its position. (In a step the
// particle boundaries set the cells, and what adds particles sets theirs.)
void update_cell_map(const GridGeometry& geometry, const ParticleState& particles, index_t first = 0);

// Algorithm 1, step 12: the particle arrays grouped by cell, in index order within a cell (the
// same order on any thread count), so that particles close in space are close in memory. The
// fields' Views may be replaced (on CPUs they are, as capacity growth replaces them): hold none
// across it. `order` is kept by the caller from reordering to reordering: its arrays (its list of
// the particles, 4.5 B a particle with its spare; 4 B a cell, and 4 more for each thread up to 32
// on CPUs, 4 more on GPUs) are made again only where the particles outgrow them or the cells
// change. (Made for each reordering, they were three or four allocations every reordering: on a
// GPU each a cudaMalloc, and a free that may wait for the device.)
void reorder_particles_by_cell(ParticleState& particles, index_t num_cells, CellOrder& order);

// The number of particles with an invalid gas state (is_valid_gas_state: a NaN or non-positive
// density, a NaN pressure, or a signal speed |v| + c that is not finite); the time step's check.
index_t count_invalid_gas_states(const ParticleState& particles, real_t gamma);
// The lowest index of a particle with an invalid gas state or position; particles.count if none.
index_t first_invalid_particle(const ParticleState& particles, real_t gamma);
// The index of the particle with the largest signal speed |v| + c (the time step is set by the
// nodes, which it usually dominates when the step collapses); -1 without particles.
index_t fastest_particle(const ParticleState& particles, real_t gamma);

}  // namespace mpmflow
