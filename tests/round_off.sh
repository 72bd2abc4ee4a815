# Bounds for the binary's reals, sourced by the script tests: as tests/round_off.hpp's
# per_precision, a bound on round-off that a run grows is double's, or single precision's own
# (double's scaled by the epsilons' ratio, 2^29, would be too loose to catch a fault).
#   reals=$(reals_of MPMFLOW_BINARY)             "double" or "single", as its `--version` names them
#   per_precision "$reals" IN_DOUBLE IN_SINGLE   prints the bound for those reals
# (The binary is asked once, in an assignment, so that a failure stops the script under set -e.)
reals_of() {
  local version
  version=$("$1" --version) || { echo "FAIL: $1 --version failed" >&2; return 1; }
  case $version in
    *"single precision"*) echo single ;;
    *"double precision"*) echo double ;;
    *) echo "FAIL: $1 --version names no precision" >&2; return 1 ;;
  esac
}
per_precision() {
  case $1 in
    single) echo "$3" ;;
    double) echo "$2" ;;
    *) echo "FAIL: per_precision: reals '$1', expected double or single" >&2; return 1 ;;
  esac
}
