#!/usr/bin/env bash
# ctest: Riemann problems nobody tuned the method to, against a first-order Godunov scheme with
# exact Riemann fluxes on the same cells (tools/mpmflow_plot.py godunov-error), density L1 with
# particle-free gaps as vacuum on [0, 1] at 100 cells per unit length:
#   Toro's tests 1, 3 and 4 (cases/toro_sonic_rarefaction, toro_strong_shock, toro_shock_collision):
#   at most Godunov's (seen: 0.0106 / 0.0130, 0.068 / 0.221, 0.585 / 0.901);
#   Toro's test 5 (cases/toro_slow_shock, a shock moving slowly across the grid): at most 3 x
#   Godunov's, a guard on a known weakness (seen: 0.112 / 0.044; see the README);
#   LeBlanc's shock tube (cases/leblanc.json, density ratio 1000, pressure ratio 1e9, on [0, 9]): at
#   most Godunov's (seen: 0.0128 / 0.0306).
# And Noh's problem (cases/noh.json, c0 = 4): the plateau's density and pressure within 1 % of 4
# and 4/3, scattered by at most 5 % (seen: +0.25 %, -0.11 %, 3.3 %, 0.34 %); with the paper's c0 = 1
# (37 %, 95 %, means 18 % and 39 % high) it must fail (the check can fail).
# Usage: riemann_problems.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3
rm -rf "$work_dir"
mkdir -p "$work_dir"
plot=(/usr/bin/python3 "$source_dir/tools/mpmflow_plot.py")
status=0
# name:factor:x_lo:x_hi, the L1 measured on [x_lo, x_hi]
for entry in toro_sonic_rarefaction:1:0:1 toro_strong_shock:1:0:1 toro_shock_collision:1:0:1 toro_slow_shock:3:0:1 \
             leblanc:1:0:9; do
  IFS=: read -r name factor x_lo x_hi <<< "$entry"
  "$binary" run "$source_dir/cases/$name.json" --output "$work_dir/$name" > "$work_dir/$name.log"
  run=$("${plot[@]}" riemann-error "$work_dir/$name" --mpmflow "$binary" --x "$x_lo" "$x_hi")
  reference=$("${plot[@]}" godunov-error "$work_dir/$name" --mpmflow "$binary" --x "$x_lo" "$x_hi")
  echo "$run"
  echo "$reference"
  l1=$(sed -n 's/.*density L1 (gaps as vacuum) \([0-9.e+-]*\);.*/\1/p' <<< "$run")
  godunov=$(sed -n 's/.*density L1 \([0-9.e+-]*\)$/\1/p' <<< "$reference")
  if [ -z "$l1" ] || [ -z "$godunov" ]; then
    echo "FAILED: $name: could not read the two L1 errors"
    status=1
  elif /usr/bin/python3 -c "import sys; sys.exit(0 if $l1 <= $factor * $godunov else 1)"; then
    echo "$name: L1 $l1 <= $factor x Godunov's $godunov"
  else
    echo "FAILED: $name: L1 $l1 > $factor x Godunov's $godunov"
    status=1
  fi
done
plateau=(scatter --x 0.05 0.17 --density 4 --pressure 1.3333333333 --max-mean-error 0.01
         --max-density-scatter 0.05 --max-pressure-scatter 0.05)
"$binary" run "$source_dir/cases/noh.json" --output "$work_dir/noh" > "$work_dir/noh.log"
"${plot[@]}" "${plateau[@]}" "$work_dir/noh" --out "$work_dir/noh.png" || status=1
"$binary" run "$source_dir/cases/noh.json" --set physics/artificial_viscosity/c0=1 --output "$work_dir/noh_c0_1" \
  > "$work_dir/noh_c0_1.log"
if "${plot[@]}" "${plateau[@]}" "$work_dir/noh_c0_1" --out "$work_dir/noh_c0_1.png" > "$work_dir/noh_c0_1_check.log"; then
  cat "$work_dir/noh_c0_1_check.log"
  echo "FAILED: Noh with c0 = 1 met the plateau bounds; the check cannot tell"
  status=1
else
  grep -E "^(density|pressure) +scatter" "$work_dir/noh_c0_1_check.log" | sed "s/^/noh, c0 = 1: /"
fi
exit $status
