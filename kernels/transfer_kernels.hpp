#pragma once
// The four generic particle/grid transfer kernels of the paper (eqs. 16-19), as templates over
// on-the-fly functors (the paper's Figs. 1-4). The mapped quantity is never stored: a functor
// computes it from state arrays for one particle (P2G, P2GD) or one node (G2P, G2PD), and for the
// grid-to-particle kernels a second functor (the "sink") consumes the interpolated value for that
// particle, so a physics update can be fused into the interpolation loop without a temporary.
//
// Functor contracts, with N = Functor::num_components:
//   P2G  particle functor:  void operator()(index_t p, real_t (&value)[N]) const
//   P2GD particle functor:  void operator()(index_t p, real_t (&vector)[N][2]) const
//   G2P  node functor:      void operator()(index_t node, real_t (&value)[N]) const
//        sink:              void operator()(index_t p, const real_t (&value)[N]) const
//   G2PD node functor as G2P; sink: void operator()(index_t p, const real_t (&gradient)[N][2]) const
//
// The shape-function policy (kernels/shape_functions.hpp) gives each particle's stencil of nodes,
// weights and weight gradients, so the same kernels serve linear MPM and GIMP.
//
// P2G and P2GD accumulate through a Kokkos ScatterView (duplicated or atomic, chosen by its type),
// into columns [first_component, first_component + N) of a (node, component) View. No hand-written
// atomics: the ScatterView decides how concurrent contributions to one node are combined.
#include <Kokkos_ScatterView.hpp>

#include "kernels/shape_functions.hpp"

namespace mpmflow {

// Where the particles are: positions and the cell map kept in step with them.
struct ParticleLocations {
  RealView x;
  RealView y;
  IndexView cell;
};

// The ScatterView type used for P2G, parameterised by its duplication mode. Duplicated copies
// combine without atomics (the CPU default); non-duplicated ones need atomic contributions.
template <class Duplication>
struct ScatterContributionFor {
  using type = Kokkos::Experimental::ScatterNonAtomic;
};
template <>
struct ScatterContributionFor<Kokkos::Experimental::ScatterNonDuplicated> {
  using type = Kokkos::Experimental::ScatterAtomic;
};

template <class Duplication>
using NodeScatterView =
    Kokkos::Experimental::ScatterView<real_t**, Kokkos::LayoutLeft, DeviceType,
                                      Kokkos::Experimental::ScatterSum, Duplication,
                                      typename ScatterContributionFor<Duplication>::type>;

// Prepares a ScatterView for a P2G into `target` columns that the caller has zeroed: duplicated
// copies are cleared; an atomic ScatterView writes into `target` itself and must not clear the
// columns other P2G passes have already filled.
template <class ScatterViewType>
void p2g_begin(ScatterViewType& scatter, const NodeFieldsView& target) {
  scatter.reset_except(target);
}

// Combines the duplicated copies into `target` (no-op for an atomic ScatterView).
template <class ScatterViewType>
void p2g_end(ScatterViewType& scatter, const NodeFieldsView& target) {
  scatter.contribute_into(target);
}

// Runs body(p, stencil) for every particle p, with its stencil from the shape policy: the one
// particle loop all four transfer kernels share.
template <class Shape, class Body>
void for_each_particle_stencil(const char* label, const Shape& shape, const ParticleLocations& particles,
                               index_t num_particles, const Body& body) {
  const auto x = particles.x;
  const auto y = particles.y;
  const auto cell = particles.cell;
  Kokkos::parallel_for(
      label, Kokkos::RangePolicy<ExecutionSpace>(0, num_particles),
      KOKKOS_LAMBDA(const index_t p) { body(p, shape(p, cell(p), x(p), y(p))); });
}

// P2G (eq. 16): node(i, c) += sum_p F_c(p) phi_i(X_p).
template <class Shape, class ScatterViewType, class ParticleFunctor>
void p2g(const char* label, const Shape& shape, const ParticleLocations& particles, index_t num_particles,
         ScatterViewType& scatter, int first_component, const ParticleFunctor& functor) {
  constexpr int N = ParticleFunctor::num_components;
  for_each_particle_stencil(
      label, shape, particles, num_particles, KOKKOS_LAMBDA(const index_t p, const auto& s) {
        real_t value[N];
        functor(p, value);
        auto access = scatter.access();
        for (int a = 0; a < Shape::stencil_size; ++a)
          for (int c = 0; c < N; ++c) access(s.node[a], first_component + c) += s.weight[a] * value[c];
      });
}

// P2GD (eq. 18): node(i, c) += sum_p G_c(p) . grad phi_i(X_p).
template <class Shape, class ScatterViewType, class ParticleFunctor>
void p2gd(const char* label, const Shape& shape, const ParticleLocations& particles, index_t num_particles,
          ScatterViewType& scatter, int first_component, const ParticleFunctor& functor) {
  constexpr int N = ParticleFunctor::num_components;
  for_each_particle_stencil(
      label, shape, particles, num_particles, KOKKOS_LAMBDA(const index_t p, const auto& s) {
        real_t vector[N][2];
        functor(p, vector);
        auto access = scatter.access();
        for (int a = 0; a < Shape::stencil_size; ++a)
          for (int c = 0; c < N; ++c)
            access(s.node[a], first_component + c) += vector[c][0] * s.grad_x[a] + vector[c][1] * s.grad_y[a];
      });
}

// P2G and P2GD fused (Algorithm 1, step 3): one pass, one stencil evaluation per particle, for
// node(i, value columns) += F(p) phi_i and node(i, vector columns) += G(p) . grad phi_i into the
// same ScatterView. Worth it because the stencil (and for GIMP its weights) dominates both.
template <class Shape, class ScatterViewType, class ValueFunctor, class VectorFunctor>
void p2g_and_p2gd(const char* label, const Shape& shape, const ParticleLocations& particles,
                  index_t num_particles, ScatterViewType& scatter, int first_value_component,
                  const ValueFunctor& value_functor, int first_vector_component,
                  const VectorFunctor& vector_functor) {
  constexpr int NV = ValueFunctor::num_components;
  constexpr int ND = VectorFunctor::num_components;
  for_each_particle_stencil(
      label, shape, particles, num_particles, KOKKOS_LAMBDA(const index_t p, const auto& s) {
        real_t value[NV];
        real_t vector[ND][2];
        value_functor(p, value);
        vector_functor(p, vector);
        auto access = scatter.access();
        for (int a = 0; a < Shape::stencil_size; ++a) {
          for (int c = 0; c < NV; ++c) access(s.node[a], first_value_component + c) += s.weight[a] * value[c];
          for (int c = 0; c < ND; ++c)
            access(s.node[a], first_vector_component + c) += vector[c][0] * s.grad_x[a] + vector[c][1] * s.grad_y[a];
        }
      });
}

// G2P (eq. 17): value_c(p) = sum_i F_c(node i) phi_i(X_p), handed to sink(p, value).
template <class Shape, class NodeFunctor, class ParticleSink>
void g2p(const char* label, const Shape& shape, const ParticleLocations& particles, index_t num_particles,
         const NodeFunctor& node_functor, const ParticleSink& sink) {
  constexpr int N = NodeFunctor::num_components;
  for_each_particle_stencil(
      label, shape, particles, num_particles, KOKKOS_LAMBDA(const index_t p, const auto& s) {
        real_t value[N];
        for (int c = 0; c < N; ++c) value[c] = 0;
        for (int a = 0; a < Shape::stencil_size; ++a) {
          real_t node_value[N];
          node_functor(s.node[a], node_value);
          for (int c = 0; c < N; ++c) value[c] += s.weight[a] * node_value[c];
        }
        sink(p, value);
      });
}

// G2PD (eq. 19): gradient_c(p) = sum_i F_c(node i) grad phi_i(X_p), handed to sink(p, gradient).
template <class Shape, class NodeFunctor, class ParticleSink>
void g2pd(const char* label, const Shape& shape, const ParticleLocations& particles, index_t num_particles,
          const NodeFunctor& node_functor, const ParticleSink& sink) {
  constexpr int N = NodeFunctor::num_components;
  for_each_particle_stencil(
      label, shape, particles, num_particles, KOKKOS_LAMBDA(const index_t p, const auto& s) {
        real_t gradient[N][2];
        for (int c = 0; c < N; ++c) gradient[c][0] = gradient[c][1] = 0;
        for (int a = 0; a < Shape::stencil_size; ++a) {
          real_t node_value[N];
          node_functor(s.node[a], node_value);
          for (int c = 0; c < N; ++c) {
            gradient[c][0] += s.grad_x[a] * node_value[c];
            gradient[c][1] += s.grad_y[a] * node_value[c];
          }
        }
        sink(p, gradient);
      });
}

}  // namespace mpmflow
