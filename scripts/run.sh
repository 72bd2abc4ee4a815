#!/usr/bin/env bash
# README command 1: set up, build, and run the default case (cases/sod.json), writing its
# output to output/sod. Extra arguments go to `mpmflow run`, e.g. --set domain/cells_x=400.
set -euo pipefail
project_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$project_dir"
bash scripts/build.sh openmp
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
# --overwrite: the main job rewrites its own output folder each time it is run.
build/openmp/bin/mpmflow run cases/sod.json --output output/sod --overwrite "$@"
echo "Output: $project_dir/output/sod (HDF5 snapshots, sod_particles.xmf and sod_grid.xmf for ParaView, diagnostics.csv)"
