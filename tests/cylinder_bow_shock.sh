#!/usr/bin/env bash
# ctest: the Mach 3 cylinder at a coarse resolution, its bow shock measured from the HDF5 output by
# the plotting tool (tools/mpmflow_plot.py bow-shock), with looser bounds than at the default
# resolution. Usage: cylinder_bow_shock.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3
rm -rf "$work_dir"
mkdir -p "$work_dir"
"$binary" run "$source_dir/cases/cylinder_mach3.json" --output "$work_dir/output" --progress-interval 1000 \
  --set domain/cells_x=100 --set domain/cells_y=50 --set particles/per_cell=[3,3] --set output/snapshots=20
# Debian's python3 (h5py, matplotlib), not a pyenv shim first on PATH.
/usr/bin/python3 "$source_dir/tools/mpmflow_plot.py" bow-shock "$work_dir/output" --last 10 \
  --max-standoff-error 0.3 --max-pitot-error 0.35
