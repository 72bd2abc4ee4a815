#include "particles.hpp"

#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "counter_random.hpp"
#include "gas_physics.hpp"
#include "geometry.hpp"
#include "kernels/particle_sort.hpp"
#include "kernels/reductions.hpp"

namespace mpmflow {
namespace {

// `field` moved to new storage of `capacity` entries: its first `count` copied, the rest unset
// (beyond the particle count, as a reorder leaves them). Kokkos::resize zeroed the whole new View,
// then copied the old one's whole extent, every new page written twice: the 12 fields of 881,000
// particles growing by an eighth took 36-43 ms that way, 23-27 ms this way
// (docs/performance_history.md).
template <class ViewType>
void move_to_larger_storage(ViewType& field, index_t capacity, index_t count) {
  const ViewType grown(Kokkos::view_alloc(Kokkos::WithoutInitializing, field.label()), capacity);
  const auto in_use = std::make_pair(index_t(0), count);
  Kokkos::deep_copy(Kokkos::subview(grown, in_use), Kokkos::subview(field, in_use));
  field = grown;
}

}  // namespace

ParticleState::ParticleState(index_t n)
    : count(n),
      position_x("particle_position_x", n),
      position_y("particle_position_y", n),
      velocity_x("particle_velocity_x", n),
      velocity_y("particle_velocity_y", n),
      mass("particle_mass", n),
      density("particle_density", n),
      specific_energy("particle_specific_energy", n),
      artificial_viscosity("particle_artificial_viscosity", n),
      domain_stretch_x("particle_domain_stretch_x", n),
      domain_stretch_y("particle_domain_stretch_y", n),
      cell("particle_cell", n),
      id("particle_id", n) {}

WholeParticles::WholeParticles(const ParticleState& particles) {
  particles.for_each_field([this](const auto& field) {
    using Field = std::decay_t<decltype(field)>;
    // (A field type or count not provided for here is a compile-time or first-use error, not a
    // particle copied in part.)
    static_assert(std::is_same<Field, RealView>::value || std::is_same<Field, IndexView>::value ||
                      std::is_same<Field, ParticleIdView>::value,
                  "WholeParticles: a particle field of a type it does not hold");
    int& count = std::is_same<Field, RealView>::value    ? num_reals
                 : std::is_same<Field, IndexView>::value ? num_indices
                                                         : num_ids;
    if (count == max_fields_of_a_type)
      throw std::logic_error("WholeParticles: more particle fields of a type than max_fields_of_a_type");
    if constexpr (std::is_same<Field, RealView>::value) reals[count] = field;
    else if constexpr (std::is_same<Field, IndexView>::value) indices[count] = field;
    else ids[count] = field;
    ++count;
  });
}

void copy_particles(const char* label, const ParticleState& particles, const IndexView& destinations, index_t first,
                    const IndexView& sources, index_t n) {
  if (n <= 0) return;
  const WholeParticles whole(particles);
  const bool listed = destinations.extent(0) > 0;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, n),
      KOKKOS_LAMBDA(const index_t k) { whole.copy(listed ? destinations(k) : first + k, sources(k)); });
}

void ParticleState::reserve(index_t n) {
  if (n <= capacity()) return;
  const index_t kept = count;
  for_each_field_mutable([n, kept](auto& field) { move_to_larger_storage(field, n, kept); });
}

GasState initial_state_at(const InitialStateConfig& initial, real_t x, real_t y) {
  GasState state = initial.background;
  for (const Region& region : initial.regions)
    if (x >= region.x_min && x < region.x_max && y >= region.y_min && y < region.y_max) state = region.state;
  return state;
}

namespace {

// A host list into the first entries of a particle field (which on a GPU lives on the device).
template <class T, class FieldView>
void copy_list_to_field(const std::vector<T>& values, const FieldView& field) {
  using HostList = Kokkos::View<const T*, typename FieldView::array_layout, Kokkos::HostSpace, Kokkos::MemoryUnmanaged>;
  Kokkos::deep_copy(Kokkos::subview(field, std::make_pair(size_t(0), values.size())),
                    HostList(values.data(), values.size()));
}

// A particle field, each particle's entry a function of the initial gas state at its position, made
// on the host (in the field itself on CPUs, in a host copy of it on a GPU).
template <class ValueOfState>
void fill_from_initial_state(const RealView& field, const std::vector<real_t>& xs, const std::vector<real_t>& ys,
                             const InitialStateConfig& initial, const ValueOfState& value_of) {
  const auto host = host_mirror(field);
  for (size_t k = 0; k < xs.size(); ++k) host(k) = value_of(initial_state_at(initial, xs[k], ys[k]));
  Kokkos::deep_copy(field, host);
}

}  // namespace

ParticleState create_initial_particles(const CaseConfig& config, const GridSlab& slab) {
  const int ppx = config.particles.per_cell_x;
  const int ppy = config.particles.per_cell_y;
  const index_t per_cell = ppx * ppy;
  const real_t hx = slab.geometry.spacing_x;
  const real_t hy = slab.geometry.spacing_y;
  const bool random = config.particles.placement == ParticlePlacement::random;
  const HostObstacleSet obstacles = make_host_obstacle_set(config.obstacles);

  // Positions and ids first, on the host once at start-up: the count is known only after the
  // points inside obstacles are dropped. A cell cut by an obstacle so keeps its fluid share.
  std::vector<real_t> xs, ys;
  std::vector<particle_id_t> ids;
  const IndexRange2D owned = slab.index_space(Ownership::owned, Entity::cell, Indexing::global);
  for (index_t cj = owned.begin_y; cj < owned.end_y; ++cj)
    for (index_t ci = owned.begin_x; ci < owned.end_x; ++ci)
      for (int b = 0; b < ppy; ++b)
        for (int a = 0; a < ppx; ++a) {
          // Global and cell-major, so ids do not depend on how the grid is split.
          const particle_id_t id = (static_cast<particle_id_t>(cj) * slab.global_cells_x + ci) * per_cell + b * ppx + a;
          // Regular: the centres of a ppx x ppy sub-grid of the cell. Random: uniform in its own
          // cell of that sub-grid (stratified, as the free stream enters at open sides), from the
          // counter-based generator at step 0 (recycling uses steps >= 1). Uniform in the whole
          // cell, as the paper draws them, the particles clump: their volumes tile the space
          // unevenly, and the uniform pressure pushes the gas about, twice the density scatter
          // (7.5 % against 3.2 % in a Mach 0.3 tunnel at t = 1, tests/free_stream_noise.sh).
          const real_t in_x = random ? real_t(counter_uniform(config.particles.seed, id, 0, 0)) : real_t(0.5);
          const real_t in_y = random ? real_t(counter_uniform(config.particles.seed, id, 0, 1)) : real_t(0.5);
          const real_t fx = (a + in_x) / ppx, fy = (b + in_y) / ppy;  // the place in the cell
          const real_t px = slab.domain_x_min + hx * (ci + fx);
          const real_t py = slab.domain_y_min + hy * (cj + fy);
          if (!obstacles.empty() && obstacles(px, py).distance <= 0) continue;
          xs.push_back(px);
          ys.push_back(py);
          ids.push_back(id);
        }

  // The fields one at a time, so that the host holds one field's copy at most beside the lists
  // above: on a GPU the eight host copies made at once had been the run's whole memory peak (64 of
  // its 156 B a particle on an H200, mpmflow_benchmarks --memory-breakdown). Positions and ids go
  // over straight from the lists.
  ParticleState particles(static_cast<index_t>(xs.size()));
  copy_list_to_field(xs, particles.position_x);
  copy_list_to_field(ys, particles.position_y);
  copy_list_to_field(ids, particles.id);
  const real_t particle_volume = slab.cell_area() / per_cell;
  const real_t gamma = config.physics.gamma;
  const InitialStateConfig& initial = config.initial_state;
  fill_from_initial_state(particles.velocity_x, xs, ys, initial, [](const GasState& s) { return s.velocity_x; });
  fill_from_initial_state(particles.velocity_y, xs, ys, initial, [](const GasState& s) { return s.velocity_y; });
  fill_from_initial_state(particles.density, xs, ys, initial, [](const GasState& s) { return s.density; });
  fill_from_initial_state(particles.mass, xs, ys, initial,
                          [particle_volume](const GasState& s) { return s.density * particle_volume; });
  fill_from_initial_state(particles.specific_energy, xs, ys, initial, [gamma](const GasState& s) {
    return perfect_gas_specific_energy(gamma, s.density, s.pressure);
  });
  fill_in_order(particles.domain_stretch_x, real_t(1));
  fill_in_order(particles.domain_stretch_y, real_t(1));
  update_cell_map(slab.geometry, particles);
  return particles;
}

void update_cell_map(const GridGeometry& geometry, const ParticleState& particles, index_t first) {
  const auto x = particles.position_x;
  const auto y = particles.position_y;
  const auto cell = particles.cell;
  Kokkos::parallel_for(
      "update_cell_map", Kokkos::RangePolicy<ExecutionSpace>(first, particles.count),
      KOKKOS_LAMBDA(const index_t p) { cell(p) = geometry.cell_of(x(p), y(p)); });
}

void reorder_particles_by_cell(ParticleState& particles, index_t num_cells, CellOrder& order) {
  order.build(particles.cell, particles.count, num_cells);
  if constexpr (cpu_code_paths) {
    // Each field gathered into new storage, the old freed: the bytes moved once (the freed blocks
    // are reused at once on the host: reuse_freed_host_memory).
    particles.for_each_field_mutable([&](auto& field) { field = order.apply(field); });
  } else {
    // In place through one scratch: one allocation a reorder, not one a field.
    const PermutationScratch scratch(Kokkos::view_alloc(Kokkos::WithoutInitializing, std::string("reorder_scratch")),
                                     static_cast<size_t>(particles.count));
    particles.for_each_field_mutable([&](const auto& field) { order.apply_in_place(field, scratch); });
  }
}

index_t count_invalid_gas_states(const ParticleState& particles, real_t gamma) {
  const auto vx = particles.velocity_x, vy = particles.velocity_y, e = particles.specific_energy,
             rho = particles.density;
  return count_particles(
      "invalid_gas_states", particles.count, KOKKOS_LAMBDA(const index_t k) {
        const real_t p = perfect_gas_pressure(gamma, rho(k), e(k));
        return !is_valid_gas_state(rho(k), p, signal_speed(vx(k), vy(k), perfect_gas_sound_speed(gamma, e(k))));
      });
}

index_t fastest_particle(const ParticleState& particles, real_t gamma) {
  if (particles.count == 0) return -1;
  const auto vx = particles.velocity_x, vy = particles.velocity_y, e = particles.specific_energy;
  using Reducer = Kokkos::MaxLoc<real_t, index_t>;
  typename Reducer::value_type fastest;
  Kokkos::parallel_reduce(
      "fastest_particle", Kokkos::RangePolicy<ExecutionSpace>(0, particles.count),
      KOKKOS_LAMBDA(const index_t k, typename Reducer::value_type& best) {
        const real_t speed = signal_speed(vx(k), vy(k), perfect_gas_sound_speed(gamma, e(k)));
        if (speed > best.val || (speed == best.val && k < best.loc)) {
          best.val = speed;
          best.loc = k;
        }
      },
      Reducer(fastest));
  return fastest.loc;
}

index_t first_invalid_particle(const ParticleState& particles, real_t gamma) {
  const auto x = particles.position_x, y = particles.position_y, vx = particles.velocity_x,
             vy = particles.velocity_y, e = particles.specific_energy, rho = particles.density;
  index_t first = particles.count;
  Kokkos::parallel_reduce(
      "find_invalid_particle", Kokkos::RangePolicy<ExecutionSpace>(0, particles.count),
      KOKKOS_LAMBDA(const index_t k, index_t& smallest) {
        const real_t p = perfect_gas_pressure(gamma, rho(k), e(k));
        const real_t speed = signal_speed(vx(k), vy(k), perfect_gas_sound_speed(gamma, e(k)));
        const bool valid = is_valid_gas_state(rho(k), p, speed) && x(k) == x(k) && y(k) == y(k);
        if (!valid && k < smallest) smallest = k;
      },
      Kokkos::Min<index_t>(first));
  return first < particles.count ? first : particles.count;  // the reduction's identity when none is bad
}

}  // namespace mpmflow
