#!/bin/bash
# Distributed-run tests, run by ctest (tests/CMakeLists.txt). Each runs mpmflow under mpirun at
# several rank counts and checks the outputs with tools/compare_outputs.py (Debian's python3).
#
#   mpi_runs.sh TEST MPIEXEC MPMFLOW SOURCE_DIR WORK_DIR
#
# TEST: sod | cylinder | restart | stop | errors. Open MPI needs --oversubscribe for more ranks than
# cores, and refuses to run as root unless told that it is wanted (CI runs as root).
set -euo pipefail
test_name=$1 mpiexec=$2 mpmflow=$3 source_dir=$4 work=$5
source "$(dirname "${BASH_SOURCE[0]}")/round_off.sh"
reals=$(reals_of "$mpmflow")
python=/usr/bin/python3
compare="$python $source_dir/tools/compare_outputs.py"
if [ "$(id -u)" = 0 ]; then export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1; fi
export OMP_NUM_THREADS=1 OMP_PROC_BIND=false
mpi_flags=()
mpi_version=$("$mpiexec" --version 2>&1 || true)
if [[ $mpi_version == *"Open MPI"* || $mpi_version == *"OpenRTE"* ]]; then mpi_flags=(--oversubscribe); fi
rm -rf "$work"
mkdir -p "$work"

# stops_with_message LOG EXPECTED WHAT COMMAND...: COMMAND (an mpirun of ranks that must fail)
# within 60 s, its output in LOG; every rank must stop (no hang) and LOG must hold EXPECTED.
stops_with_message() {
  local log=$1 expected=$2 what=$3 status
  shift 3
  set +e
  timeout 60 "$@" > "$log" 2>&1
  status=$?
  set -e
  grep "mpmflow: error" "$log" || true
  [ $status -ne 124 ] || { echo "FAILED: $what: the job hangs"; exit 1; }
  grep -q "$expected" "$log" || { echo "FAILED: $what: no message '$expected' (exit $status)"; exit 1; }
}

# run NP OUTPUT_DIR CASE [mpmflow options...]: mpmflow on NP ranks, its log in OUTPUT_DIR.log
run() {
  local np=$1 out=$2 case_file=$3
  shift 3
  if ! "$mpiexec" "${mpi_flags[@]}" -np "$np" "$mpmflow" run "$case_file" --output "$out" --progress-interval 1000 "$@" \
      > "$out.log" 2>&1; then
    echo "FAILED: mpirun -np $np mpmflow run $case_file $*"
    cat "$out.log"
    exit 1
  fi
}

# The coarse cylinder: 60 x 30 cells, 4 random particles per cell, t = 0.5 (about 90 steps; round-off
# differences between rank counts grow from 3e-15 at t = 0.125 to 6e-14 at t = 0.375 and 9e-13
# at t = 0.5, as they do between 1 and 2 threads on one rank with the duplicated P2G, 6e-13),
# slabs rebalanced every 10 steps. (While obstacles let the gas leave their surface, the wake's
# near-empty nodes magnified round-off to 2e-10 by t = 0.5, and to 2.2e-7 with the random particles
# stratified.) Particle splitting on (and merging, by default): the split halves' ids and the
# merged pairs must not depend on the ranks (827 split halves of 7577 particles at t = 0.5), and
# restarts must carry the split count. In single precision the differences start at float's
# round-off (seen: Sod 2.6e-5, the cylinder 2.3e-4, a restart on other rank counts 5.1e-6; bounds
# 1e-3, 1e-2 and 1e-4 there, against double's 1e-10, 1e-9 and 1e-10).
cylinder=("$source_dir/cases/cylinder_mach3.json" --set domain/cells_x=60 --set domain/cells_y=30
          --set 'particles/per_cell=[2,2]' --set time/end=0.5 --set output/snapshots=4
          --set decomposition/balance_interval=10 --set numerics/split_particles=true)
sod_bound=$(per_precision "$reals" 1e-10 1e-3) cylinder_bound=$(per_precision "$reals" 1e-9 1e-2)
restart_bound=$(per_precision "$reals" 1e-10 1e-4)

case $test_name in
  sod)
    for np in 1 2 4; do run $np "$work/np$np" "$source_dir/cases/sod.json"; done
    for np in 2 4; do $compare "$work/np1" "$work/np$np" --all --tolerance "$sod_bound" | tail -2; done
    # A 1D case's picture is line profiles along x (written from a folder that holds checkpoints
    # of nothing else, and from the 4-rank output).
    /usr/bin/python3 "$source_dir/tools/mpmflow_plot.py" fields "$work/np4" --out "$work/plots" | grep -q "_profiles.png" \
      || { echo "FAILED: no profile plot of the 1D case"; exit 1; }
    ;;
  cylinder)
    for np in 1 2 4; do run $np "$work/np$np" "${cylinder[@]}"; done
    # The slabs must really have moved, or the test would not cover rebalancing.
    grep "load balance" "$work/np4.log" | head -3
    grep -q "load balance" "$work/np4.log" || { echo "FAILED: no rebalancing in the 4-rank run"; exit 1; }
    for np in 2 4; do $compare "$work/np1" "$work/np$np" --all --tolerance "$cylinder_bound" | tail -2; done
    # Slabs along y instead (30 cells: 4 slabs of 7 or 8 rows).
    run 4 "$work/np4y" "${cylinder[@]}" --set decomposition/axis=y
    grep -q "slabs along y" "$work/np4y.log" || { echo "FAILED: not decomposed along y"; exit 1; }
    $compare "$work/np1" "$work/np4y" --all --tolerance "$cylinder_bound" | tail -2
    ;;
  restart)
    # Checkpoints every 25 steps; restarts from the one at step 50 (between outputs 2 and 3).
    checkpoints=(--set output/checkpoint_interval=25 --set output/checkpoints_kept=0)
    run 2 "$work/whole" "${cylinder[@]}" "${checkpoints[@]}"
    checkpoint="$work/whole/cylinder_mach3_checkpoint_000000050.h5"
    [ -f "$checkpoint" ] || { echo "FAILED: no checkpoint at step 50"; ls "$work/whole"; exit 1; }
    [ -f "$work/whole/cylinder_mach3_checkpoint_000000025.h5" ] || { echo "FAILED: no checkpoint at step 25"; exit 1; }
    ls "$work/whole" | grep -q '\.tmp$' && { echo "FAILED: a temporary file was left behind"; exit 1; }
    for np in 2 1 4; do
      mkdir -p "$work/restart$np"
      cp "$work/whole/cylinder_mach3_00000"[012].h5 "$work/whole/diagnostics.csv" "$work/restart$np/"
      run $np "$work/restart$np" "${cylinder[@]}" "${checkpoints[@]}" --restart "$checkpoint"
      grep -q "restart from .*step 50" "$work/restart$np.log" || { echo "FAILED: no restart line"; exit 1; }
    done
    # Same rank count: bitwise, every output after the restart; other rank counts: round-off.
    for step in 3 4; do $compare "$work/whole" "$work/restart2" --step $step --exact | tail -1; done
    for np in 1 4; do $compare "$work/whole" "$work/restart$np" --step 4 --tolerance "$restart_bound" | tail -1; done
    # The diagnostics continue where they were: the same rows as the uninterrupted run.
    cmp "$work/whole/diagnostics.csv" "$work/restart2/diagnostics.csv"
    # The XDMF series of the restarted run lists all five outputs.
    [ "$(grep -c '<Time ' "$work/restart2/cylinder_mach3_particles.xmf")" = 5 ] || { echo "FAILED: XDMF series"; exit 1; }
    ;;
  stop)
    # SIGTERM to one rank alone: the ranks take its request together (in the reduction of the next
    # step's time step) and all stop after the same step, with a checkpoint and exit code 3; continued
    # on 2 ranks, the run ends bitwise where an uninterrupted run ends.
    long=("${cylinder[@]}" --set time/end=2)
    run 2 "$work/whole" "${long[@]}"
    # (Within a time limit: ranks that did not stop together would wait on each other for ever.)
    timeout 120 "$mpiexec" "${mpi_flags[@]}" -np 2 "$mpmflow" run "${long[@]}" --output "$work/stopped" \
      --set output/checkpoint_interval=20 --set output/checkpoints_kept=0 > "$work/stopped.log" 2>&1 &
    job=$!
    # Once the checkpoint of step 20 is there (a file the ranks write, not output that mpirun
    # forwards late), one rank is told to stop (timeout's child is mpirun, whose children are the ranks).
    for _ in $(seq 600); do [ -f "$work/stopped/cylinder_mach3_checkpoint_000000020.h5" ] && break; sleep 0.05; done
    launcher=$(pgrep -P $job | head -1)
    rank=$(pgrep -P "${launcher:-0}" | tail -1)
    [ -n "$rank" ] || { echo "FAILED: no rank process under mpirun $job"; exit 1; }
    kill -TERM "$rank"
    status=0
    wait $job || status=$?
    grep "stopped by" "$work/stopped.log" || true
    [ $status -eq 3 ] || { tail -3 "$work/stopped.log"; echo "FAILED: exit code $status, expected 3"; exit 1; }
    [ "$(grep -c 'stopped by SIGTERM' "$work/stopped.log")" = 1 ] || { echo "FAILED: not one stop message"; exit 1; }
    checkpoint=$(ls "$work/stopped"/*_checkpoint_*.h5 | sort | tail -1)
    run 2 "$work/stopped" "${long[@]}" --restart "$checkpoint"
    $compare "$work/whole" "$work/stopped" --step 4 --exact | tail -1
    ;;
  errors)
    # A bad case file: one message (from rank 0), exit code 2 from the job.
    printf '{ "name": "bad", "domain": { "cells_x": "many" } }' > "$work/bad.json"
    set +e
    "$mpiexec" "${mpi_flags[@]}" -np 2 "$mpmflow" run "$work/bad.json" > "$work/bad.log" 2>&1
    status=$?
    set -e
    cat "$work/bad.log" | grep "mpmflow: error" || true
    [ $status -ne 0 ] || { echo "FAILED: exit status 0 for a bad case"; exit 1; }
    [ "$(grep -c 'mpmflow: error' "$work/bad.log")" = 1 ] || { echo "FAILED: the error must be printed once"; exit 1; }
    grep -q "bad.json: /domain" "$work/bad.log" || { echo "FAILED: the message must name the file and key"; exit 1; }
    # More ranks than the grid allows (Sod has 100 cells along x: at most 33 slabs of 3 cells).
    set +e
    "$mpiexec" "${mpi_flags[@]}" -np 4 "$mpmflow" run "$source_dir/cases/sod.json" --set domain/cells_x=10 \
      --output "$work/too_many" > "$work/too_many.log" 2>&1
    status=$?
    set -e
    grep "mpmflow: error" "$work/too_many.log" || true
    [ $status -ne 0 ] || { echo "FAILED: exit status 0 with too many ranks"; exit 1; }
    [ "$(grep -c 'cannot be split among 4 ranks' "$work/too_many.log")" = 1 ] || { echo "FAILED: rank-count message"; exit 1; }
    # Ranks given different command lines (here --output): every rank stops at once, exit 2.
    stops_with_message "$work/different.log" "rank 1 was given another command line than rank 0" \
      "ranks given different --output" \
      "$mpiexec" "${mpi_flags[@]}" -np 1 "$mpmflow" run "$source_dir/cases/sod.json" --output "$work/out_a" : \
      -np 1 "$mpmflow" run "$source_dir/cases/sod.json" --output "$work/out_b"
    # A checkpoint one rank cannot see (the same relative path, another working directory): every
    # rank stops within the timeout, the message names the rank.
    "$mpmflow" run "$source_dir/cases/sod.json" --set domain/cells_x=20 --set output/checkpoint_interval=10 \
      --output "$work/with_checkpoint" --progress-interval 1000 > /dev/null
    mkdir -p "$work/sees" "$work/blind"
    cp "$(ls "$work/with_checkpoint"/*_checkpoint_*.h5 | head -1)" "$work/sees/ck.h5"
    stops_with_message "$work/blind.log" "no such checkpoint file (on rank 1)" \
      "a checkpoint missing on one rank" \
      "$mpiexec" "${mpi_flags[@]}" -np 1 -wdir "$work/sees" "$mpmflow" run --restart ck.h5 --output out : \
      -np 1 -wdir "$work/blind" "$mpmflow" run --restart ck.h5 --output out
    ;;
  *)
    echo "unknown test $test_name"
    exit 2
    ;;
esac
echo "PASSED: $test_name"
