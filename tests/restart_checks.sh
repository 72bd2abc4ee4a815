#!/usr/bin/env bash
# ctest: what a restart accepts. From a checkpoint of the Sod case at step 40 (t ~ 0.087 of 0.143):
# - without a case file it runs the checkpoint's own case, and ends bitwise where an uninterrupted
#   run ends;
# - another snapshot count (the output schedule may change) writes the next snapshot at the first
#   time of the new schedule after the checkpoint's, and the run ends there;
# - another gamma (a physics key) is refused, naming the key (exit 2, nothing run);
# - a checkpoint whose time is NaN is refused (exit 2).
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
echo "restart checks: OK"
