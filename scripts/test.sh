#!/usr/bin/env bash
# README command 2: set up, build, and run every test through ctest.
set -euo pipefail
project_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$project_dir"
bash scripts/build.sh openmp
ctest --preset openmp
