#!/usr/bin/env bash
# ctest: Toro's test 2 (cases/toro_near_vacuum.json) at 100 and 400 cells over [0, 1]: positive
# states (the run checks them every step), no particle-free gap wider than two cells, and the
# density L1 error with gaps counted as vacuum at most 1.5 x that of a first-order Godunov scheme
# with exact Riemann fluxes at CFL 0.9 (0.0164 at 100 cells, 0.0071 at 400). Without particle
# splitting a gap of some 25 cells opens: that run must fail the gap bound (the check can fail).
# Usage: near_vacuum.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3
rm -rf "$work_dir"
mkdir -p "$work_dir"
measure=(/usr/bin/python3 "$source_dir/tools/mpmflow_plot.py" riemann-error --x 0 1 --mpmflow "$binary")
case_file="$source_dir/cases/toro_near_vacuum.json"
"$binary" run "$case_file" --output "$work_dir/100" > "$work_dir/100.log"
"${measure[@]}" "$work_dir/100" --max-l1 0.0246 --max-gap 2
"$binary" run "$case_file" --set domain/cells_x=800 --output "$work_dir/400" > "$work_dir/400.log"
"${measure[@]}" "$work_dir/400" --max-l1 0.01065 --max-gap 2
"$binary" run "$case_file" --set numerics/split_particles=false --output "$work_dir/unsplit" > "$work_dir/unsplit.log"
if "${measure[@]}" "$work_dir/unsplit" --max-gap 2 > "$work_dir/unsplit_check.log"; then
  cat "$work_dir/unsplit_check.log"
  echo "FAILED: without splitting the gap bound still held; the check cannot tell"
  exit 1
fi
sed 's/^/without splitting: /' "$work_dir/unsplit_check.log" | head -1
