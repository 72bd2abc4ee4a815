#!/usr/bin/env bash
# README command 2: set up, build, and run every test through ctest: in the default build
# (openmp), then in the build that takes the GPU build's code paths on the host (gpu-paths: the
# kernels' GPU forms and the MPI staging through host mirrors, which the default build never runs),
# then in single precision (single: float reals, the tests' bounds on round-off float's).
# All run even where one fails; the exit status is the first failure's.
set -euo pipefail
project_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$project_dir"
status=0
for preset in openmp gpu-paths single; do
  bash scripts/build.sh "$preset"
  ctest --preset "$preset" || { rc=$?; [ "$status" -ne 0 ] || status=$rc; }
done
exit "$status"
