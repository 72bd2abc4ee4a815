#!/usr/bin/env bash
# ctest: the cylinder case at Mach 5, a free stream it was not tuned to (the case file's is Mach 3),
# coarse (150 x 75 cells, the radius 9.4 cells): its bow shock against Billig's stand-off and the
# pitot pressure of Mach 5, which the plotting tool takes from the run's own case (its free stream
# and circle). Seen at t = 1.5: stand-off 19.8 % short, nose pressure 5.2 % low (10.4 % and 4.0 %
# at the default 200 x 100 cells). Until 2026-12-06 the check ran at 100 x 50 cells, where the
# stand-off spans two cells: 23.0 % short then; since the bodies press on the gas with its pressure
# (boundary_conditions.cpp, ObstaclePressure), 31.9 % there, while at 150 x 75 and 200 x 100 it came
# closer than before (22.2 % and 13.9 % before).
# Usage: cylinder_mach5_bow_shock.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3
rm -rf "$work_dir"
mkdir -p "$work_dir"
"$binary" run "$source_dir/cases/cylinder_mach3.json" --output "$work_dir/output" --progress-interval 1000 \
  --set 'free_stream/velocity=[5,0]' --set domain/cells_x=150 --set domain/cells_y=75 --set time/end=1.5 \
  --set output/snapshots=10
# Debian's python3 (h5py, matplotlib), not a pyenv shim first on PATH.
/usr/bin/python3 "$source_dir/tools/mpmflow_plot.py" bow-shock "$work_dir/output" --last 5 \
  --max-standoff-error 0.3 --max-pitot-error 0.1
