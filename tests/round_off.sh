# Bounds for the binary's reals, sourced by the script tests: as tests/round_off.hpp's
# per_precision, a bound on round-off that a run grows is double's, or single precision's own
# (double's scaled by the epsilons' ratio, 2^29, would be too loose to catch a fault).
#   per_precision MPMFLOW_BINARY IN_DOUBLE IN_SINGLE   prints the one for the binary's reals
# The reals are what `mpmflow --version` names ("double precision" or "single precision").
per_precision() {
  local version
  version=$("$1" --version) || { echo "FAIL: $1 --version failed" >&2; return 1; }
  case $version in
    *"single precision"*) echo "$3" ;;
    *"double precision"*) echo "$2" ;;
    *) echo "FAIL: $1 --version names no precision" >&2; return 1 ;;
  esac
}
