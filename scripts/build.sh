#!/usr/bin/env bash
# Sets up (scripts/setup.sh), then configures and builds one CMake preset (default: openmp).
# Usage: scripts/build.sh [PRESET]
set -euo pipefail
project_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
preset=${1:-openmp}
cd "$project_dir"
# The last line of setup.sh names the Kokkos it settled on (.deps/install, or Kokkos_ROOT).
read -r -a kokkos_args <<<"$(bash scripts/setup.sh | tail -n 1)"
cmake --preset "$preset" "${kokkos_args[@]}" >/dev/null
cmake --build --preset "$preset" -j "$(nproc 2>/dev/null || echo 2)"
