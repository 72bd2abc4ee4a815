#!/usr/bin/env bash
# ctest: what a restart accepts. From a checkpoint of the Sod case at step 40 (t ~ 0.087 of 0.143):
# - without a case file it runs the checkpoint's own case, and ends bitwise where an uninterrupted
#   run ends;
# - given a folder instead of a file, it continues from the folder's newest checkpoint (bitwise as
#   above), and refuses a folder with none or with checkpoints of two cases, naming the folder;
# - another snapshot count (the output schedule may change) writes the next snapshot at the first
#   time of the new schedule after the checkpoint's, and the run ends there;
# - another gamma (a physics key) is refused, naming the key (exit 2, nothing run);
# - a checkpoint whose time is NaN is refused (exit 2);
# - a snapshot (with the case file or without) or another HDF5 file is refused saying what it is
#   (exit 2).
# Usage: restart_checks.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3
rm -rf "$work_dir"
mkdir -p "$work_dir"
export OMP_PROC_BIND=false
sod=("$source_dir/cases/sod.json" --progress-interval 1000 --set output/snapshots=4 --set 'numerics/p2g="sorted"')
"$binary" run "${sod[@]}" --output "$work_dir/whole" > "$work_dir/whole.log"
"$binary" run "${sod[@]}" --output "$work_dir/first" --set output/checkpoint_interval=40 --set output/checkpoints_kept=0 \
  > "$work_dir/first.log"
checkpoint=$(ls "$work_dir"/first/sod_checkpoint_000000040.h5)

# Without a case file, into a copy of the first run's folder.
cp -r "$work_dir/first" "$work_dir/resumed"
"$binary" run --restart "$work_dir/resumed/$(basename "$checkpoint")" --output "$work_dir/resumed" > "$work_dir/resumed.log"
/usr/bin/python3 "$source_dir/tools/compare_outputs.py" "$work_dir/whole" "$work_dir/resumed" --exact | tail -1
/usr/bin/python3 "$source_dir/tools/compare_outputs.py" "$work_dir/whole" "$work_dir/resumed" --exact > /dev/null \
  || { echo "FAIL: a restart without a case file does not end bitwise where the whole run ends"; exit 1; }

# A folder instead of a file: its newest checkpoint. With the run's last checkpoint gone from a
# copy of its folder, the newest is step 40's, and the run ends bitwise where the whole one ends.
cp -r "$work_dir/first" "$work_dir/from_folder"
last_checkpoint=$(ls "$work_dir"/from_folder/sod_checkpoint_*.h5 | tail -1)
[ "$(basename "$last_checkpoint")" != "$(basename "$checkpoint")" ] \
  || { echo "FAIL: the first run wrote no checkpoint after step 40"; exit 1; }
"$binary" run --restart "$work_dir/from_folder" --output "$work_dir/from_folder" > "$work_dir/from_folder_last.log"
grep -q "restart from $last_checkpoint: step" "$work_dir/from_folder_last.log" \
  || { echo "FAIL: --restart FOLDER did not take the newest checkpoint, $last_checkpoint"; exit 1; }
rm "$last_checkpoint"
"$binary" run --restart "$work_dir/from_folder" --output "$work_dir/from_folder" > "$work_dir/from_folder.log"
grep "restart from" "$work_dir/from_folder.log"
grep -q "restart from $work_dir/from_folder/$(basename "$checkpoint"): step 40," "$work_dir/from_folder.log" \
  || { echo "FAIL: --restart FOLDER did not take the newest checkpoint left, step 40's"; exit 1; }
/usr/bin/python3 "$source_dir/tools/compare_outputs.py" "$work_dir/whole" "$work_dir/from_folder" --exact > /dev/null \
  || { echo "FAIL: a restart from a folder does not end bitwise where the whole run ends"; exit 1; }
# A folder with no checkpoint, and one with checkpoints of two cases (the continued run above has
# written its last checkpoint again): refused (exit 2), naming the folder.
mkdir -p "$work_dir/no_checkpoint"
cp "$checkpoint" "$work_dir/from_folder/another_case_checkpoint_000000007.h5"
for folder in no_checkpoint from_folder; do
  status=0
  "$binary" run --restart "$work_dir/$folder" > "$work_dir/$folder.refused.log" 2>&1 || status=$?
  tail -1 "$work_dir/$folder.refused.log"
  [ "$status" -eq 2 ] && grep -q "mpmflow: error: --restart $work_dir/$folder: " "$work_dir/$folder.refused.log" \
    || { echo "FAIL: --restart $folder was not refused naming the folder (exit $status)"; exit 1; }
done
grep -q "the folder holds none" "$work_dir/no_checkpoint.refused.log" \
  && grep -q "checkpoints of 2 cases (the newest of each: another_case_checkpoint_000000007.h5, $(basename "$last_checkpoint"))" \
    "$work_dir/from_folder.refused.log" || { echo "FAIL: the refusals do not say what the folders hold"; exit 1; }

# Another snapshot count: 10 instead of 4: the next output is the first of the new schedule after the checkpoint.
t_checkpoint=$(/usr/bin/python3 -c "import h5py,sys; print(h5py.File(sys.argv[1]).attrs['time'])" "$checkpoint")
cp -r "$work_dir/first" "$work_dir/rescheduled"
"$binary" run --restart "$work_dir/rescheduled/$(basename "$checkpoint")" --output "$work_dir/rescheduled" \
  --set output/snapshots=10 > "$work_dir/rescheduled.log"
first_output=$(grep -m1 "  output " "$work_dir/rescheduled.log")
echo "checkpoint at t = $t_checkpoint; then: $first_output"
/usr/bin/python3 - "$t_checkpoint" "$first_output" <<'PY' || { echo "FAIL: the first output after the restart is not the next one scheduled"; exit 1; }
import re, sys
import h5py
t0 = float(sys.argv[1])
m = re.search(r"output (\d+) at t = \S+: (\S+)", sys.argv[2])
k, path = int(m.group(1)), m.group(2)
t = float(h5py.File(path).attrs["time"])  # the file's time (the log rounds it)
expected_k = next(i for i in range(1, 11) if 0.143 * i / 10 > t0 * (1 + 1e-12))
assert k == expected_k and abs(t - 0.143 * k / 10) < 1e-12, (k, t, expected_k)
PY

# Another gamma: refused, naming the key.
status=0
"$binary" run --restart "$checkpoint" --output "$work_dir/gamma" --set physics/gamma=1.67 > "$work_dir/gamma.log" 2>&1 || status=$?
tail -1 "$work_dir/gamma.log"
[ "$status" -eq 2 ] && grep -q "the case differs from the checkpoint's at /physics/gamma: 1.4 in the checkpoint, 1.67 now" \
  "$work_dir/gamma.log" || { echo "FAIL: a restart with another gamma was not refused (exit $status)"; exit 1; }

# A checkpoint edited to t = NaN: refused.
cp "$checkpoint" "$work_dir/nan.h5"
/usr/bin/python3 -c "import h5py,sys; f=h5py.File(sys.argv[1],'r+'); f.attrs['time']=float('nan')" "$work_dir/nan.h5"
status=0
"$binary" run --restart "$work_dir/nan.h5" --output "$work_dir/nan" > "$work_dir/nan.log" 2>&1 || status=$?
tail -1 "$work_dir/nan.log"
[ "$status" -eq 2 ] && grep -q "expected a time >= 0" "$work_dir/nan.log" \
  || { echo "FAIL: a checkpoint at t = NaN was not refused (exit $status)"; exit 1; }

# A snapshot, with the case file and without, and the grid's mesh file: refused, saying what they are.
snapshot=$(ls "$work_dir"/first/sod_00000[0-9].h5 | tail -1)
for given in "--restart $snapshot" "$source_dir/cases/sod.json --restart $snapshot" \
    "--restart $work_dir/first/sod_grid_mesh.h5"; do
  status=0
  # shellcheck disable=SC2086  # (the words of $given are the arguments)
  "$binary" run $given --output "$work_dir/not_a_checkpoint" > "$work_dir/not_a_checkpoint.log" 2>&1 || status=$?
  tail -1 "$work_dir/not_a_checkpoint.log"
  case $given in *grid_mesh*) what="not an mpmflow checkpoint" ;; *) what="a snapshot, not a checkpoint" ;; esac
  [ "$status" -eq 2 ] && grep -q "mpmflow: error: --restart .*: $what" "$work_dir/not_a_checkpoint.log" \
    || { echo "FAIL: run $given was not refused as $what (exit $status)"; exit 1; }
done
echo "restart checks: OK"
