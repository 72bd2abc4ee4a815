#!/usr/bin/env bash
# Idempotent set-up for mpmflow on Debian 12.
#  1. installs the Debian packages the build, the tests and the tools need (only the missing ones);
#  2. finds Kokkos + Kokkos Kernels: an installed Kokkos named by Kokkos_ROOT is used as it is;
#     otherwise Kokkos and Kokkos Kernels 3.4 are built from Debian's `trilinos` source package
#     (OpenMP + Serial, Kokkos Kernels ETI off) into .deps/install, and reused on later runs.
# Prints, as its last line, the CMake cache arguments that point at the Kokkos it settled on,
# so callers can do: cmake_args=$(scripts/setup.sh | tail -n 1).
set -euo pipefail

project_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
deps_dir="$project_dir/.deps"
prefix="$deps_dir/install"
jobs=$(nproc 2>/dev/null || echo 2)

log() { echo "[setup] $*" >&2; }

as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

packages=(build-essential cmake dpkg-dev pkg-config
  openmpi-bin libopenmpi-dev libhdf5-openmpi-dev nlohmann-json3-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3-h5py python3-matplotlib python3-numpy
  python3-jsonschema python3-paraview xvfb xauth python3-meshio
  clang libomp-dev)

missing=()
for pkg in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)
  [ "$status" = "install ok installed" ] || missing+=("$pkg")
done
if [ ${#missing[@]} -gt 0 ]; then
  log "installing Debian packages: ${missing[*]}"
  as_root apt-get update -q >&2
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${missing[@]}" >&2
else
  log "Debian packages: all present"
fi

# --- Kokkos -----------------------------------------------------------------------------------
if [ -n "${Kokkos_ROOT:-}" ]; then
  log "using the Kokkos named by Kokkos_ROOT=$Kokkos_ROOT"
  kernels_root=${KokkosKernels_ROOT:-$Kokkos_ROOT}
  echo "-DKokkos_ROOT=$Kokkos_ROOT -DKokkosKernels_ROOT=$kernels_root"
  exit 0
fi

# A Kokkos that CMake finds by itself (installed in a system prefix, or on CMAKE_PREFIX_PATH).
probe_dir=$(mktemp -d)
trap 'rm -rf "$probe_dir"' EXIT
cat >"$probe_dir/CMakeLists.txt" <<'PROBE'
cmake_minimum_required(VERSION 3.16)
project(mpmflow_kokkos_probe CXX)
find_package(Kokkos CONFIG QUIET)
if(Kokkos_FOUND)
  file(WRITE "${CMAKE_BINARY_DIR}/kokkos_dir" "${Kokkos_DIR}")
endif()
find_package(KokkosKernels CONFIG QUIET)
if(KokkosKernels_FOUND)
  file(WRITE "${CMAKE_BINARY_DIR}/kokkos_kernels_dir" "${KokkosKernels_DIR}")
endif()
PROBE
if cmake -S "$probe_dir" -B "$probe_dir/build" >/dev/null 2>&1 && [ -f "$probe_dir/build/kokkos_dir" ]; then
  kokkos_dir=$(cat "$probe_dir/build/kokkos_dir")
  log "using the Kokkos CMake finds: $kokkos_dir"
  args="-DKokkos_DIR=$kokkos_dir"
  [ -f "$probe_dir/build/kokkos_kernels_dir" ] && args="$args -DKokkosKernels_DIR=$(cat "$probe_dir/build/kokkos_kernels_dir")"
  echo "$args"
  exit 0
fi

if [ -f "$prefix/.complete" ]; then
  log "reusing Kokkos + Kokkos Kernels in $prefix"
  echo "-DKokkos_ROOT=$prefix -DKokkosKernels_ROOT=$prefix"
  exit 0
fi

src_dir="$deps_dir/src"
mkdir -p "$src_dir"
if [ ! -d "$src_dir/kokkos" ] || [ ! -d "$src_dir/kokkos-kernels" ]; then
  src_list=/etc/apt/sources.list.d/mpmflow-deb-src.sources
  if ! grep -rqs '^Types:.*deb-src' /etc/apt/sources.list.d/ && ! grep -qs '^deb-src' /etc/apt/sources.list; then
    log "adding a bookworm deb-src entry ($src_list)"
    as_root tee "$src_list" >/dev/null <<'SRC'
Types: deb-src
URIs: http://deb.debian.org/debian
Suites: bookworm
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SRC
    as_root apt-get update -q >&2
  fi
  download_dir="$deps_dir/download"
  mkdir -p "$download_dir"
  if ! ls "$download_dir"/trilinos_*.orig.tar.* >/dev/null 2>&1; then
    log "fetching Debian's trilinos source package"
    (cd "$download_dir" && apt-get source --download-only trilinos >&2)
  fi
  # Only Kokkos and Kokkos Kernels are needed: extract those two directories, not all of Trilinos.
  log "extracting packages/kokkos and packages/kokkos-kernels"
  rm -rf "$src_dir/extract" && mkdir -p "$src_dir/extract"
  tar -xf "$download_dir"/trilinos_*.orig.tar.* -C "$src_dir/extract" \
    --wildcards '*/packages/kokkos/*' '*/packages/kokkos-kernels/*'
  rm -rf "$src_dir/kokkos" "$src_dir/kokkos-kernels"
  mv "$src_dir"/extract/*/packages/kokkos "$src_dir/kokkos"
  mv "$src_dir"/extract/*/packages/kokkos-kernels "$src_dir/kokkos-kernels"
  rm -rf "$src_dir/extract"
fi

log "building Kokkos (OpenMP + Serial) into $prefix"
cmake -S "$src_dir/kokkos" -B "$deps_dir/build-kokkos" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_INSTALL_PREFIX="$prefix" -DCMAKE_CXX_STANDARD=17 \
  -DKokkos_ENABLE_OPENMP=ON -DKokkos_ENABLE_SERIAL=ON -DBUILD_SHARED_LIBS=ON >&2
cmake --build "$deps_dir/build-kokkos" -j "$jobs" >&2
cmake --install "$deps_dir/build-kokkos" >&2

log "building Kokkos Kernels (ETI off) into $prefix"
cmake -S "$src_dir/kokkos-kernels" -B "$deps_dir/build-kokkos-kernels" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_INSTALL_PREFIX="$prefix" -DKokkos_ROOT="$prefix" -DBUILD_SHARED_LIBS=ON \
  -DKokkosKernels_INST_DOUBLE=OFF -DKokkosKernels_INST_OFFSET_INT=OFF \
  -DKokkosKernels_INST_OFFSET_SIZE_T=OFF -DKokkosKernels_INST_ORDINAL_INT=OFF \
  -DKokkosKernels_INST_LAYOUTLEFT=OFF -DKokkosKernels_INST_LAYOUTRIGHT=OFF \
  -DKokkosKernels_ENABLE_TESTS=OFF -DKokkosKernels_ENABLE_EXAMPLES=OFF >&2
cmake --build "$deps_dir/build-kokkos-kernels" -j "$jobs" >&2
cmake --install "$deps_dir/build-kokkos-kernels" >&2

touch "$prefix/.complete"
log "Kokkos + Kokkos Kernels ready in $prefix"
echo "-DKokkos_ROOT=$prefix -DKokkosKernels_ROOT=$prefix"
