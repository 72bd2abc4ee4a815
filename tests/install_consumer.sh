#!/usr/bin/env bash
# ctest: cmake --install of this build into a fresh prefix, then a consumer project configured with
# find_package(mpmflow) against it, built and run; the installed binary, tools and cases work.
# Usage: install_consumer.sh BUILD_DIR SOURCE_DIR WORK_DIR
set -euo pipefail
build_dir=$1 source_dir=$2 work_dir=$3
rm -rf "$work_dir"
mkdir -p "$work_dir"
prefix="$work_dir/prefix"
cmake --install "$build_dir" --prefix "$prefix" > "$work_dir/install.log"
for path in bin/mpmflow lib/cmake/mpmflow/mpmflowConfig.cmake share/mpmflow/cases/sod.json \
            share/mpmflow/cases/mpmflow_case.schema.json share/mpmflow/tools/mpmflow_plot.py include/mpmflow/solver.hpp; do
  [ -e "$prefix/$path" ] || { echo "FAIL: $path not installed"; exit 1; }
done
cmake -S "$source_dir/tests/consumer" -B "$work_dir/consumer" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release > "$work_dir/configure.log" 2>&1 || { cat "$work_dir/configure.log"; echo "FAIL: configure"; exit 1; }
cmake --build "$work_dir/consumer" -j 2 > "$work_dir/build.log" 2>&1 || { tail -30 "$work_dir/build.log"; echo "FAIL: build"; exit 1; }
OMP_PROC_BIND=false "$work_dir/consumer/consumer" --kokkos-threads=1
binary=$(cat "$work_dir/consumer/mpmflow_binary.txt")
[ "$binary" = "$prefix/bin/mpmflow" ] || { echo "FAIL: mpmflow::mpmflow is '$binary'"; exit 1; }
"$binary" --version | head -1
OMP_PROC_BIND=false "$binary" run "$prefix/share/mpmflow/cases/sod.json" --set domain/cells_x=20 \
  --output "$work_dir/run" --progress-interval 1000 > "$work_dir/run.log"
/usr/bin/python3 "$prefix/share/mpmflow/tools/mpmflow_plot.py" fields "$work_dir/run" --out "$work_dir/plots" | tail -1
echo "installed and consumed: OK"
