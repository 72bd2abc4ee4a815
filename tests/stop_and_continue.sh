#!/usr/bin/env bash
# ctest: a run stopped by SIGTERM, and one stopped by --wall-time, exit with code 3 after writing a
# checkpoint; one killed by SIGKILL (maybe in the middle of writing a checkpoint: one every 5
# steps) leaves its newest complete checkpoint. Continued with --restart (no case file) they end
# bitwise where an uninterrupted run ends. (The run takes about 6 s on one thread here; the stops come after 1.5 and 2 s.)
# Usage: stop_and_continue.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3
rm -rf "$work_dir"
mkdir -p "$work_dir"
export OMP_PROC_BIND=false OMP_NUM_THREADS=1
cylinder=("$source_dir/cases/cylinder_mach3.json" --progress-interval 1000 --set domain/cells_x=100 --set domain/cells_y=50
  --set time/end=2 --set output/snapshots=4 --set 'numerics/p2g="sorted"')
"$binary" run "${cylinder[@]}" --output "$work_dir/whole" > "$work_dir/whole.log"
for how in sigterm walltime sigkill; do
  status=0
  if [ $how = sigterm ]; then
    "$binary" run "${cylinder[@]}" --output "$work_dir/$how" > "$work_dir/$how.log" 2>&1 &
    pid=$!
    sleep 1.5
    kill -TERM $pid
    wait $pid || status=$?
  elif [ $how = sigkill ]; then
    "$binary" run "${cylinder[@]}" --output "$work_dir/$how" --set output/checkpoint_interval=5 > "$work_dir/$how.log" 2>&1 &
    pid=$!
    sleep 1.7
    kill -KILL $pid
    wait $pid || status=$?
    [ "$status" -eq 137 ] || { echo "FAIL: sigkill: the run was not killed (exit $status)"; exit 1; }
    status=3  # as if stopped: continue from the newest complete checkpoint
  else
    "$binary" run "${cylinder[@]}" --output "$work_dir/$how" --wall-time 00:00:02 > "$work_dir/$how.log" 2>&1 || status=$?
  fi
  grep "stopped by" "$work_dir/$how.log" || true
  [ "$status" -eq 3 ] || { tail -3 "$work_dir/$how.log"; echo "FAIL: $how: exit code $status, expected 3"; exit 1; }
  checkpoint=$(ls "$work_dir/$how"/*_checkpoint_*.h5 | sort | tail -1)  # not a .tmp left by SIGKILL
  "$binary" run --restart "$checkpoint" --output "$work_dir/$how" > "$work_dir/$how.continued.log"
  /usr/bin/python3 "$source_dir/tools/compare_outputs.py" "$work_dir/whole" "$work_dir/$how" --exact | tail -1
  /usr/bin/python3 "$source_dir/tools/compare_outputs.py" "$work_dir/whole" "$work_dir/$how" --exact > /dev/null \
    || { echo "FAIL: $how: the continued run does not end where the whole run ends"; exit 1; }
done
echo "stop and continue: OK"
