#!/usr/bin/env bash
# ctest: builds the case parser's libFuzzer target with Debian's clang (address and undefined-
# behaviour sanitizers) and runs it for a bounded time, seeded with the shipped cases. A crash, a
# sanitizer report or an escaping exception fails the test and leaves the input in WORK_DIR.
# Exits 77 (skipped) without clang++ and libFuzzer (Debian: clang, libomp-dev).
# Usage: fuzz_case_parser.sh SOURCE_DIR WORK_DIR KOKKOS_INCLUDE_DIRS KOKKOS_CORE_LIBRARY SECONDS
set -euo pipefail
source_dir=$1 work_dir=$2 kokkos_includes=$3 kokkos_library=$4 seconds=$5
command -v clang++ > /dev/null || { echo "SKIP: clang++ not found"; exit 77; }
rm -rf "$work_dir"
mkdir -p "$work_dir/corpus"
cp "$source_dir"/cases/*.json "$work_dir/corpus/"
includes=(-I"$source_dir/src" -I"$source_dir")
IFS=';' read -ra dirs <<< "$kokkos_includes"
for d in "${dirs[@]}"; do includes+=(-I"$d"); done
if ! clang++ -std=c++17 -O1 -g -fopenmp -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
    "${includes[@]}" "$source_dir/tests/fuzz/case_parser_fuzzer.cpp" "$source_dir/src/case_config.cpp" \
    "$source_dir/src/geometry.cpp" "$source_dir/src/grid.cpp" "$kokkos_library" -Wl,-rpath,"$(dirname "$kokkos_library")" \
    -o "$work_dir/case_parser_fuzzer" > "$work_dir/build.log" 2>&1; then
  if grep -q "fsanitize=fuzzer\|omp.h\|libomp" "$work_dir/build.log"; then
    tail -5 "$work_dir/build.log"; echo "SKIP: no libFuzzer or OpenMP for clang here"; exit 77
  fi
  tail -20 "$work_dir/build.log"; echo "FAIL: the fuzz target does not build"; exit 1
fi
cd "$work_dir"
if ! ./case_parser_fuzzer -max_total_time="$seconds" -max_len=4096 -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 corpus > fuzz.log 2>&1; then
  grep -E "ERROR|SUMMARY|Test unit written|deadly" fuzz.log | head -10
  echo "FAIL: the case parser fuzzer found a problem (the input is in $work_dir)"
  exit 1
fi
grep -E "stat::number_of_executed_units|stat::new_units_added" fuzz.log
echo "fuzzed the case parser for $seconds s: no crash, no escaping exception"
