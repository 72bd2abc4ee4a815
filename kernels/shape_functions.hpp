#pragma once
// Shape functions of the Cartesian grid, as policies the transfer kernels are templated on.
//  - LinearShape: the Q1 (bilinear) basis at the particle position, 4 nodes (the paper's MPM).
//  - GimpShape:   contiguous-particle GIMP (Bardenhagen & Kober 2004; Wallstedt & Guilkey 2008):
//                 the same Q1 basis averaged over the particle's axis-aligned rectangular domain,
//                 3 x 3 nodes. The domain's half-sizes follow the particle's stretches (the
//                 diagonal of its deformation gradient), so particle domains stay contiguous as
//                 the gas expands or compresses. Its weight gradients are continuous when a
//                 particle crosses a cell face, which removes the grid-crossing force noise that
//                 keeps linear MPM from converging (Steffen, Kirby & Berzins 2008).
// Each policy maps (p, cell, x, y) to a Stencil: node indices with phi_i(X_p), grad phi_i(X_p).
#include "kernels/grid_geometry.hpp"
#include "kernels/types.hpp"

namespace mpmflow {

template <int N>
struct Stencil {
  static constexpr int size = N;
  index_t node[N];
  real_t weight[N];
  real_t grad_x[N];
  real_t grad_y[N];
};

// Bilinear basis in the particle's cell. Node order: (i,j), (i+1,j), (i,j+1), (i+1,j+1).
KOKKOS_INLINE_FUNCTION Stencil<4> q1_stencil(const GridGeometry& grid, index_t cell, real_t x, real_t y) {
  const index_t ci = cell % grid.cells_x();
  const index_t cj = cell / grid.cells_x();
  // Local coordinates in [0, 1] within the cell.
  const real_t xi = (x - grid.node_x(ci)) / grid.spacing_x;
  const real_t eta = (y - grid.node_y(cj)) / grid.spacing_y;
  const real_t inv_hx = real_t(1) / grid.spacing_x;
  const real_t inv_hy = real_t(1) / grid.spacing_y;

  Stencil<4> s;
  const index_t n00 = grid.node_index(ci, cj);
  s.node[0] = n00;
  s.node[1] = n00 + 1;
  s.node[2] = n00 + grid.nodes_x;
  s.node[3] = n00 + grid.nodes_x + 1;
  s.weight[0] = (1 - xi) * (1 - eta);
  s.weight[1] = xi * (1 - eta);
  s.weight[2] = (1 - xi) * eta;
  s.weight[3] = xi * eta;
  s.grad_x[0] = -(1 - eta) * inv_hx;
  s.grad_x[1] = (1 - eta) * inv_hx;
  s.grad_x[2] = -eta * inv_hx;
  s.grad_x[3] = eta * inv_hx;
  s.grad_y[0] = -(1 - xi) * inv_hy;
  s.grad_y[1] = -xi * inv_hy;
  s.grad_y[2] = (1 - xi) * inv_hy;
  s.grad_y[3] = xi * inv_hy;
  return s;
}

// 1D GIMP weight of a node at signed distance d = x_p - x_i, and its derivative d/dx_p, for a
// particle of half-length l < h/2 (the hat function of width h averaged over [x_p - l, x_p + l]).
KOKKOS_INLINE_FUNCTION void gimp_weight_1d(real_t d, real_t h, real_t l, real_t& weight, real_t& gradient) {
  const real_t a = d < 0 ? -d : d;
  const real_t sign = d < 0 ? real_t(-1) : real_t(1);
  if (a < l) {
    weight = 1 - (d * d + l * l) / (2 * h * l);
    gradient = -d / (h * l);
  } else if (a < h - l) {
    weight = 1 - a / h;
    gradient = -sign / h;
  } else if (a < h + l) {
    const real_t r = h + l - a;
    weight = r * r / (4 * h * l);
    gradient = -sign * r / (2 * h * l);
  } else {
    weight = 0;
    gradient = 0;
  }
}

struct LinearShape {
  static constexpr int stencil_size = 4;
  // Cells this far apart along an axis share no node (the stencil spans 2 node lines).
  static constexpr int colour_period = 2;
  GridGeometry grid;
  KOKKOS_INLINE_FUNCTION Stencil<4> operator()(index_t /*particle*/, index_t cell, real_t x, real_t y) const {
    return q1_stencil(grid, cell, x, y);
  }
};

struct GimpShape {
  static constexpr int stencil_size = 9;
  // A particle of cell ci reaches node lines ci - 1 .. ci + 2: cells 4 apart share no node.
  static constexpr int colour_period = 4;
  GridGeometry grid;
  real_t initial_half_length_x;  // the particle's half-size at stretch 1
  real_t initial_half_length_y;
  RealView stretch_x;  // per particle: current length / initial length along x and y
  RealView stretch_y;

  // The 3 x 3 nodes around the node nearest to the particle; the grid's ghost layer holds the
  // outer ones for particles in boundary cells.
  // Half-size along one axis: the stretched initial size, kept within (0, h/2] so the domain
  // never reaches past the 3-node stencil.
  KOKKOS_INLINE_FUNCTION static real_t half_length(real_t initial, real_t stretch, real_t spacing) {
    const real_t l = initial * stretch;
    const real_t largest = real_t(0.5) * spacing, smallest = real_t(1e-3) * spacing;
    return l > largest ? largest : (l < smallest ? smallest : l);
  }

  KOKKOS_INLINE_FUNCTION Stencil<9> operator()(index_t p, index_t cell, real_t x, real_t y) const {
    const real_t lx = half_length(initial_half_length_x, stretch_x(p), grid.spacing_x);
    const real_t ly = half_length(initial_half_length_y, stretch_y(p), grid.spacing_y);
    const index_t ci = cell % grid.cells_x();
    const index_t cj = cell / grid.cells_x();
    const index_t ni = (x - grid.node_x(ci)) < real_t(0.5) * grid.spacing_x ? ci : ci + 1;
    const index_t nj = (y - grid.node_y(cj)) < real_t(0.5) * grid.spacing_y ? cj : cj + 1;
    real_t wx[3], gx[3], wy[3], gy[3];
    for (int a = 0; a < 3; ++a) {
      gimp_weight_1d(x - grid.node_x(ni - 1 + a), grid.spacing_x, lx, wx[a], gx[a]);
      gimp_weight_1d(y - grid.node_y(nj - 1 + a), grid.spacing_y, ly, wy[a], gy[a]);
    }
    Stencil<9> s;
    for (int b = 0; b < 3; ++b)
      for (int a = 0; a < 3; ++a) {
        const int k = a + 3 * b;
        s.node[k] = grid.node_index(ni - 1 + a, nj - 1 + b);
        s.weight[k] = wx[a] * wy[b];
        s.grad_x[k] = gx[a] * wy[b];
        s.grad_y[k] = wx[a] * gy[b];
      }
    return s;
  }
};

}  // namespace mpmflow
