#!/usr/bin/env bash
# ctest: a run whose output folder fills up (a 4 MB tmpfs) stops with one clear error (exit 1),
# leaves no temporary file, and every file it left is whole: the snapshots open, the checkpoints
# read back and a restart from the newest one runs. Exits 77 (skipped) where a tmpfs cannot be
# mounted (not root, or a container without the right).
# With MPIEXEC, also on 2 ranks (one file written through MPI-IO): the job must end, not hang.
# Usage: full_disk.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR [MPIEXEC]
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3 mpiexec=${4:-}
source "$(dirname "${BASH_SOURCE[0]}")/round_off.sh"
reals=$(reals_of "$binary")
rm -rf "$work_dir"
mkdir -p "$work_dir/disk"
if ! mount -t tmpfs -o size=4m tmpfs "$work_dir/disk" 2>/dev/null; then
  echo "SKIP: cannot mount a tmpfs here"
  exit 77
fi
trap 'umount "$work_dir/disk" 2>/dev/null || true' EXIT
export OMP_PROC_BIND=false
base_args=("$source_dir/cases/cylinder_mach3.json" --progress-interval 1000 --set domain/cells_x=60 --set domain/cells_y=30
  --set 'particles/per_cell=[2,2]' --set time/end=0.3 --set output/checkpoint_interval=5)
# The disk fills while a snapshot is written (10 snapshots, 4 MB), and while a checkpoint is (no
# snapshots, 1.5 MB: a checkpoint is 0.63 MB, so the third does not fit beside the two kept). A
# single-precision build's files are 0.56-0.59 as large, and so are its disks.
snapshots_disk=$(per_precision "$reals" 4m 2400k)
checkpoints_disk=$(per_precision "$reals" 1536k 768k)
for spec in "10 $snapshots_disk" "0 $checkpoints_disk"; do
  read -r snapshots size <<< "$spec"
  echo "== $snapshots snapshots and a checkpoint every 5 steps, into $size"
  rm -rf "$work_dir/disk/out" "$work_dir/restarted"
  mount -o remount,size=$size "$work_dir/disk"
  case_args=("${base_args[@]}" --set output/snapshots=$snapshots)
  status=0
  "$binary" run "${case_args[@]}" --output "$work_dir/disk/out" > "$work_dir/run.log" 2>&1 || status=$?
  tail -1 "$work_dir/run.log"
  [ "$status" -eq 1 ] || { echo "FAIL: exit code $status, expected 1"; exit 1; }
  grep -q "^mpmflow: error: writing .* failed (earlier files are kept): .*No space left on device" "$work_dir/run.log" \
    || { echo "FAIL: no one-line error naming the file and the full disk"; exit 1; }
  if grep -q "HDF5-DIAG" "$work_dir/run.log"; then echo "FAIL: HDF5's own diagnostics printed"; exit 1; fi
  if ls "$work_dir/disk/out" | grep -q "\.tmp$"; then echo "FAIL: temporary files left: $(ls "$work_dir/disk/out")"; exit 1; fi
  /usr/bin/python3 - "$work_dir/disk/out" <<'PY'
import glob, sys
import h5py
out = sys.argv[1]
files = sorted(glob.glob(out + "/*.h5"))
checkpoints = [f for f in files if "_checkpoint_" in f]
for f in files:
    with h5py.File(f, "r") as h:
        if "_checkpoint_" in f:
            n = sum(h["particles_per_rank"][()])
            assert all(h["particles"][name].shape[0] == n for name in h["particles"]), f
        elif "particles" in h:
            assert h["particles/position"].shape[0] == h["particles/id"].shape[0], f
print(f"{len(files)} HDF5 files left, all whole; checkpoints: {[c.split('/')[-1] for c in checkpoints]}")
if len(checkpoints) != 2:
    print("FAIL: expected the 2 newest good checkpoints (checkpoints_kept = 2)")
PY
  newest=$(ls "$work_dir/disk/out"/*_checkpoint_*.h5 | sort | tail -1)
  cp -r "$work_dir/disk/out" "$work_dir/restarted"
  "$binary" run "${case_args[@]}" --output "$work_dir/restarted" --restart "$work_dir/restarted/$(basename "$newest")" \
    > "$work_dir/restart.log" 2>&1 || { tail -3 "$work_dir/restart.log"; echo "FAIL: restart from $newest"; exit 1; }
  echo "restart from $(basename "$newest") ran to the end"
done
if [ -n "$mpiexec" ]; then
  echo "== 2 ranks, 10 snapshots and a checkpoint every 5 steps, into $snapshots_disk"
  rm -rf "$work_dir/disk/out"
  mount -o remount,size=$snapshots_disk "$work_dir/disk"
  status=0
  OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 timeout 120 "$mpiexec" -n 2 --oversubscribe "$binary" run \
    "${base_args[@]}" --set output/snapshots=10 --output "$work_dir/disk/out" > "$work_dir/ranks2.log" 2>&1 || status=$?
  grep "mpmflow: error" "$work_dir/ranks2.log" || true
  [ "$status" -ne 124 ] || { echo "FAIL: 2 ranks on a full disk hang"; exit 1; }
  [ "$status" -eq 1 ] && grep -q "^mpmflow: error: writing .* failed (earlier files are kept)" "$work_dir/ranks2.log" \
    || { echo "FAIL: 2 ranks: exit $status without the one-line error"; exit 1; }
  if ls "$work_dir/disk/out" | grep -q "\.tmp$"; then echo "FAIL: 2 ranks: temporary files left"; exit 1; fi
fi
echo "full disk: OK"
