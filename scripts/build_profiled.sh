#!/usr/bin/env bash
# A profile-guided build (GCC) of the openmp preset, into build/openmp-profiled: the GIMP step
# about 4 % faster on this project's machine (README, Benchmarks). Sets up (scripts/setup.sh),
# builds the instrumented core (preset openmp-profile-training), runs short cases with it to count
# where the time goes (build/profile), then builds every target of the preset openmp-profiled with
# those counts. Run it again after changing the sources: GCC ignores, with a warning, the counts
# of the functions that changed.
# Usage: scripts/build_profiled.sh        then: build/openmp-profiled/bin/mpmflow run CASE.json
set -euo pipefail
project_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$project_dir"
bash scripts/build.sh openmp-profile-training

# A fresh profile: the instrumented runs add their counts to the files they find.
profile_dir="$project_dir/build/profile"
rm -rf "$profile_dir" build/profile-training-output
# The training: the default shape and its paths (a bow shock on an obstacle, open sides,
# splitting and merging, reordering), the paper's linear shape, walls and a blast. One thread:
# the counters are updated atomically, which is slow where threads share them.
trained=build/openmp-profile-training/bin/mpmflow
train() {
  local name=$1
  shift
  echo "training: mpmflow run $*"
  OMP_NUM_THREADS=1 "$trained" run "$@" --set output/snapshots=0 --output "build/profile-training-output/$name" \
    --overwrite --progress-interval 60 >"build/profile-training-output.log" 2>&1 ||
    { cat build/profile-training-output.log; echo "build_profiled.sh: the training run $name failed" >&2; exit 1; }
}
mkdir -p build/profile-training-output
train cylinder cases/cylinder_mach3.json --set time/end=0.05
train cylinder_linear cases/cylinder_mach3.json --set time/end=0.05 --set numerics/shape_function=linear
train step cases/step_mach3.json --set time/end=0.15
train sedov cases/sedov.json --set time/end=0.3

# (Configuring stops, naming the folder, where the training left no profile of the core.)
bash scripts/build.sh openmp-profiled
echo "Built build/openmp-profiled (profile: $profile_dir); tests: ctest --preset openmp-profiled"
