#!/bin/bash
# The sorted (coloured) P2G is deterministic: Sod and a coarse cylinder run (random placement,
# recycling, obstacle, reordering every 20 steps) give bitwise identical snapshots with 1 and 2
# OpenMP threads and on a repeated run, and on the CPUs' code paths the same diagnostics.csv too
# (its totals summed in fixed chunks; the GPU paths' Kokkos reductions sum per thread). The fused G2P + remap P2G kernel does the same arithmetic
# in the same order as the two generic kernels; only FMA contraction, which the compiler may do
# differently in the two, separates them: 1e-14 at the first output (t = 0.25), compared to 1e-12
# (in single precision 9.3e-6, compared to 1e-4).
# (Later the round-off grows some 100-fold per quarter time unit in the wake, 1e-3 by t = 1.) Run by ctest: sorted_p2g_bitwise.sh MPMFLOW SOURCE_DIR WORK_DIR
set -euo pipefail
mpmflow=$1 source_dir=$2 work=$3
source "$(dirname "${BASH_SOURCE[0]}")/round_off.sh"
reals=$(reals_of "$mpmflow")
unfused_bound=$(per_precision "$reals" 1e-12 1e-4)
compare="/usr/bin/python3 $source_dir/tools/compare_outputs.py"
export OMP_PROC_BIND=false
rm -rf "$work"
mkdir -p "$work"
run() {  # run THREADS OUTPUT CASE [options...]
  local threads=$1 out=$2 case_file=$3
  shift 3
  OMP_NUM_THREADS=$threads "$mpmflow" run "$case_file" --set numerics/p2g=sorted --output "$out" \
    --progress-interval 1000 "$@" > "$out.log" 2>&1 || { echo "FAILED: $out"; cat "$out.log"; exit 1; }
  grep -q "P2G sorted" "$out.log" || { echo "FAILED: not the sorted P2G"; exit 1; }
}
cylinder=("$source_dir/cases/cylinder_mach3.json" --set domain/cells_x=60 --set domain/cells_y=30
          --set 'particles/per_cell=[2,2]' --set time/end=1.0 --set output/snapshots=4)
run 1 "$work/sod_1" "$source_dir/cases/sod.json"
run 2 "$work/sod_2" "$source_dir/cases/sod.json"
$compare "$work/sod_1" "$work/sod_2" --all --exact | tail -1
same_diagnostics() {  # same_diagnostics RUN_A RUN_B: on the CPUs' code paths
  grep -q "MPMFLOW_GPU_CODE_PATHS_ON_HOST" "$1.log" && return 0
  cmp "$1/diagnostics.csv" "$2/diagnostics.csv" || { echo "FAILED: $1 and $2's diagnostics.csv differ"; exit 1; }
}
same_diagnostics "$work/sod_1" "$work/sod_2"
run 1 "$work/cylinder_1" "${cylinder[@]}"
run 2 "$work/cylinder_2" "${cylinder[@]}"
run 2 "$work/cylinder_2_again" "${cylinder[@]}"
$compare "$work/cylinder_1" "$work/cylinder_2" --all --exact | tail -1
$compare "$work/cylinder_2" "$work/cylinder_2_again" --all --exact | tail -1
same_diagnostics "$work/cylinder_1" "$work/cylinder_2"
run 2 "$work/cylinder_2_unfused" "${cylinder[@]}" --set numerics/fused_kernels=false
grep -q "kernels unfused" "$work/cylinder_2_unfused.log" || { echo "FAILED: not the unfused kernels"; exit 1; }
$compare "$work/cylinder_2" "$work/cylinder_2_unfused" --step 1 --tolerance "$unfused_bound" | tail -1
echo "PASSED"
