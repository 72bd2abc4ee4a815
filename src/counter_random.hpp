#pragma once
// Counter-based random numbers: a value is a pure function of (seed, particle id, step, draw), so a
// run repeats exactly whatever the thread count, the particle order or the rank that owns the
// particle. Kokkos' random pools hand out generator states per thread, which would tie the numbers
// to the thread schedule. The mixing is SplitMix64 (Steele, Lea & Flood 2014), applied per key.
#include <cstdint>

#include <Kokkos_Core.hpp>

namespace mpmflow {

KOKKOS_INLINE_FUNCTION std::uint64_t splitmix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Uniform in [0, 1) with 53 random bits. `draw` tells apart the numbers one particle needs at one step.
KOKKOS_INLINE_FUNCTION double counter_uniform(std::uint64_t seed, std::uint64_t id, std::uint64_t step,
                                              std::uint64_t draw) {
  const std::uint64_t h = splitmix64(splitmix64(splitmix64(splitmix64(seed) ^ id) ^ step) ^ draw);
  return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0);
}

}  // namespace mpmflow
