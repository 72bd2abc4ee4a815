#!/usr/bin/env bash
# ctest: the XDMF files of a 1-rank and a 2-rank run, opened as ParaView (pvpython, under
# xvfb-run) and meshio open them, checked against the HDF5 files, and rendered to PNGs (kept in
# WORK_DIR to look at). Exits 77 (skipped) when ParaView's pvpython or xvfb-run is missing;
# scripts/setup.sh installs them.
# Usage: xdmf_readers.sh MPMFLOW_BINARY SOURCE_DIR WORK_DIR [MPIEXEC]
set -euo pipefail
binary=$1 source_dir=$2 work_dir=$3 mpiexec=${4:-}
for tool in pvpython xvfb-run; do
  command -v $tool >/dev/null || { echo "SKIP: $tool not found (Debian: python3-paraview, xvfb)"; exit 77; }
done
# One X server for the whole test: xvfb-run called twice in a row can give the second pvpython a
# display whose server is not (or no longer) there ("bad X server connection"); -noreset: Xvfb
# otherwise resets when its last client leaves, and the next pvpython may meet the reset.
if [ -z "${MPMFLOW_UNDER_XVFB:-}" ]; then
  exec xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" env MPMFLOW_UNDER_XVFB=1 bash "$0" "$@"
fi
rm -rf "$work_dir"
mkdir -p "$work_dir"
export OMP_PROC_BIND=false OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
case_args=(run "$source_dir/cases/cylinder_mach3.json" --progress-interval 1000 --set domain/cells_x=60
  --set domain/cells_y=30 --set particles/per_cell=[2,2] --set time/end=0.3 --set output/snapshots=3)
"$binary" "${case_args[@]}" --output "$work_dir/ranks1" > "$work_dir/ranks1.log"
runs=(ranks1)
if [ -n "$mpiexec" ]; then
  "$mpiexec" -n 2 --oversubscribe "$binary" "${case_args[@]}" --output "$work_dir/ranks2" > "$work_dir/ranks2.log"
  runs+=(ranks2)
fi
status=0
for run in "${runs[@]}"; do
  echo "== $run: ParaView"
  pvpython "$source_dir/tests/xdmf_paraview_check.py" "$work_dir/$run" cylinder_mach3 \
    "$work_dir/$run/cylinder_mach3" 2>&1 | grep -v "^$" || status=1
  echo "== $run: meshio"
  /usr/bin/python3 "$source_dir/tests/xdmf_meshio_check.py" "$work_dir/$run" cylinder_mach3 3 || status=1
done
exit $status
