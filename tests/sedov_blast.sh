#!/usr/bin/env bash
# ctest: the cylindrical Sedov blast (cases/sedov.json, a quarter plane) against the exact
# solution: at 60 x 60 cells total energy conserved within 1 % at t = 1, the energy balance closing
# to round-off in the closed box, and the same radius within 2 % in every direction; at 120 x 120
# cells (3 s) the same, and the shock radius within 2 % of R(1) = 0.75. (With particle splitting, the
# default, the radius is +3.1 % at 60^2, +1.7 % at 120^2 and +1.1 % at 240^2: it converges from
# above; the issue asks for 2 % at 240^2.) The whole plane, the blast in the middle of a box four
# times the quarter's at the same cells (120 x 120 over [-1.2, 1.2]^2, 24 directions): the same
# radius in every direction, and as close to R(1) as the quarter plane at 60 x 60 (seen: +3.11 %
# and a spread of 0.29 %, against +3.08 % and 0.27 % for the quarter). The paper's energy update
# must fail the energy bound (it lost 5.7 % on 2026-12-03): the check can fail.
# Usage: sedov_blast.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3
source "$(dirname "${BASH_SOURCE[0]}")/round_off.sh"
reals=$(reals_of "$binary")
# The energy balance's bound on round-off (seen in single precision: 8.7e-9, 4.9e-8, 7.0e-9).
balance_bound=$(per_precision "$reals" 1e-10 1e-6)
rm -rf "$work_dir"
mkdir -p "$work_dir"
check=(/usr/bin/python3 "$source_dir/tools/sedov_check.py")
"$binary" run "$source_dir/cases/sedov.json" --output "$work_dir/consistent" --progress-interval 100000 > "$work_dir/consistent.log"
"${check[@]}" "$work_dir/consistent" --max-energy-change 0.01 --max-balance-residual "$balance_bound" --max-anisotropy 0.02
"$binary" run "$source_dir/cases/sedov.json" --set domain/cells_x=120 --set domain/cells_y=120 \
  --output "$work_dir/consistent_120" --progress-interval 100000 > "$work_dir/consistent_120.log"
"${check[@]}" "$work_dir/consistent_120" --max-energy-change 0.01 --max-balance-residual "$balance_bound" \
  --max-radius-error 0.02 --max-anisotropy 0.02
"$binary" run "$source_dir/cases/sedov.json" --set 'domain/x=[-1.2,1.2]' --set 'domain/y=[-1.2,1.2]' \
  --set domain/cells_x=120 --set domain/cells_y=120 --set 'initial_state/regions/0/x=[-0.04,0.04]' \
  --set 'initial_state/regions/0/y=[-0.04,0.04]' --output "$work_dir/whole_plane" --progress-interval 100000 \
  > "$work_dir/whole_plane.log"
"${check[@]}" "$work_dir/whole_plane" --max-energy-change 0.01 --max-balance-residual "$balance_bound" \
  --max-radius-error 0.04 --max-anisotropy 0.02
"$binary" run "$source_dir/cases/sedov.json" --set numerics/energy_consistent=false --output "$work_dir/paper" \
  --progress-interval 100000 > "$work_dir/paper.log"
if "${check[@]}" "$work_dir/paper" --max-energy-change 0.01 > "$work_dir/paper_check.log"; then
  cat "$work_dir/paper_check.log"
  echo "FAILED: the paper's energy update passed the energy bound; the check cannot tell"
  exit 1
fi
grep "total energy change" "$work_dir/paper_check.log" | sed 's/^/paper update: /'
