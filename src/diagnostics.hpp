#pragma once
// Conservation diagnostics over the particles, computed with Kokkos Kernels' BLAS-1 routines.
#include "particles.hpp"

namespace mpmflow {

struct ConservationTotals {
  double mass = 0;
  double momentum_x = 0;
  double momentum_y = 0;
  double kinetic_energy = 0;
  double internal_energy = 0;
  double total_energy() const { return kinetic_energy + internal_energy; }
};

class DiagnosticsCalculator {
 public:
  explicit DiagnosticsCalculator(index_t capacity) : scratch_("diagnostics_scratch", capacity) {}
  ConservationTotals compute(const ParticleState& particles);

 private:
  RealView scratch_;  // M .* V, reused by every call
};

}  // namespace mpmflow
