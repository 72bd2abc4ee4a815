#!/usr/bin/env bash
# README command 2: set up, build, and run every test through ctest: in the default build
# (openmp), then in the build that takes the GPU build's code paths on the host (gpu-paths: the
# kernels' GPU forms and the MPI staging through host mirrors, which the default build never runs).
# Both run even where the first fails; the exit status is the first failure's.
set -euo pipefail
project_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$project_dir"
status=0
bash scripts/build.sh openmp
ctest --preset openmp || status=$?
bash scripts/build.sh gpu-paths
ctest --preset gpu-paths || { rc=$?; [ "$status" -ne 0 ] || status=$rc; }
exit "$status"
