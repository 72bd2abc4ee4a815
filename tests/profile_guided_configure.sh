#!/usr/bin/env bash
# ctest: the profile-guided build's configuration (cmake/MpmflowProfileGuided.cmake). Configuring
# with both MPMFLOW_PROFILE_GENERATE and MPMFLOW_PROFILE_USE, or with MPMFLOW_PROFILE_USE naming a
# folder without a profile, fails with an error naming the option and what was expected; with
# MPMFLOW_PROFILE_GENERATE alone it succeeds and instruments the core.
# Usage: profile_guided_configure.sh SOURCE_DIR WORK_DIR [-DVAR=VALUE ...] (how this build found
# Kokkos and its compiler)
set -euo pipefail
source_dir=$1 work_dir=$2
shift 2
rm -rf "$work_dir"
mkdir -p "$work_dir/empty_profile"

# configure NAME fail|succeed PATTERN -D...: configures a build folder of its own, without tests
# or benchmarks (only the configuration is checked), and looks for PATTERN in what cmake printed.
configure() {
  local name=$1 expected=$2 pattern=$3
  shift 3
  local status=0
  cmake -S "$source_dir" -B "$work_dir/$name" -DMPMFLOW_ENABLE_TESTS=OFF -DMPMFLOW_ENABLE_BENCHMARKS=OFF \
    "$@" > "$work_dir/$name.log" 2>&1 || status=$?
  if { [ "$expected" = fail ] && [ "$status" -eq 0 ]; } || { [ "$expected" = succeed ] && [ "$status" -ne 0 ]; }; then
    cat "$work_dir/$name.log"
    echo "FAIL: $name: expected configuring to $expected; cmake exited with $status"
    exit 1
  fi
  # CMake wraps its messages' lines: the pattern is looked for in the log as one line.
  local printed
  printed=$(tr -s ' \n' ' ' < "$work_dir/$name.log")
  if [[ "$printed" != *"$pattern"* ]]; then
    cat "$work_dir/$name.log"
    echo "FAIL: $name: cmake did not print '$pattern'"
    exit 1
  fi
  echo "$name: configuring did $expected, printing '$pattern'"
}

configure both fail "MPMFLOW_PROFILE_GENERATE and MPMFLOW_PROFILE_USE are both set" "$@" \
  -DMPMFLOW_PROFILE_GENERATE="$work_dir/profile" -DMPMFLOW_PROFILE_USE="$work_dir/profile"
configure empty_profile fail "MPMFLOW_PROFILE_USE=$work_dir/empty_profile: expected the mpmflow_core profile" "$@" \
  -DMPMFLOW_PROFILE_USE="$work_dir/empty_profile"
configure generate succeed "mpmflow_core instrumented for profile-guided optimisation" "$@" \
  -DMPMFLOW_PROFILE_GENERATE="$work_dir/profile"
grep -q -- "-fprofile-generate=$work_dir/profile" "$work_dir/generate/src/CMakeFiles/mpmflow_core.dir/flags.make" ||
  { echo "FAIL: the instrumented core's flags lack -fprofile-generate"; exit 1; }
echo "profile-guided configuration: OK"
