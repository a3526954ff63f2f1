#!/usr/bin/env bash
# Installs the Debian 12 packages excite needs (only those missing), then configures
# and builds the release preset. Safe to run again: it does nothing that is done.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake pkg-config git
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libeigen3-dev coinor-libipopt-dev libabsl-dev liblbfgspp-dev libsqlite3-dev
  libpqxx-dev  # the shared PostgreSQL store (--store=postgresql://...), with libpq
  postgresql-15  # its tests start a real server (initdb + pg_ctl in a temp dir)
  haproxy  # the session-routing proxy of the replica tests and deploy/compose.scale.yaml
  prometheus-cpp-dev  # the metrics endpoint (prometheus-cpp's exposer, on civetweb)
  libcpp-httplib-dev  # the live view (--web_listen)
  libmujoco-dev  # found by path: its CMake package would demand OpenGL and qhull
  libgtest-dev libgmock-dev libbenchmark-dev
  liblapack-dev libblas-dev  # ipopt.pc links -llapack -lblas (only recommended)
  libopenblas0-serial liblapacke-dev  # the GP's LAPACK and BLAS (see below); lapack.h
  # Python client and its tests (Debian's /usr/bin/python3; nothing from PyPI)
  python3-grpcio python3-protobuf python3-numpy python3-pytest python3-yaml
  python3-venv python3-setuptools python3-wheel  # pip install client/python into a venv, offline
  python3-mypy  # type check of the Python client (ctest python_typecheck)
  python3-matplotlib  # bench/paper: the paper-table runner's plots
  python3-sklearn  # bench/gp/fit_vs_sklearn.py: the side-by-side fit comparison
  chromium chromium-driver python3-selenium  # tests/web: the live view in a real browser
  openssl                    # TLS tests make their certificates at test time
  clang libclang-rt-14-dev   # tests/fuzz: libFuzzer target (config_fuzz_30s)
  # container smoke test (tests/container): podman with runc, a local base image, compose
  podman runc netavark aardvark-dns debootstrap podman-compose
  iptables  # netavark (podman's network backend) runs it: without it every container fails
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
    missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "excite: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
    "${missing[@]}"
fi

# The GP and Ipopt call the system's libblas.so.3 and liblapack.so.3; installing
# libopenblas0-serial selects it unless a threaded OpenBLAS is installed, which
# excite-server refuses (server/gp/dense_linear_algebra.h says why): then select
# the serial build.
multiarch=$(gcc -print-multiarch)
for lib in libblas.so.3 liblapack.so.3; do
  selected=$(update-alternatives --query "$lib-$multiarch" | awk '/^Value:/ {print $2}')
  case "$selected" in
    */openblas-pthread/* | */openblas-openmp/*)
      echo "excite: selecting OpenBLAS's serial build for $lib (was $selected)"
      SUDO=""
      [ "$(id -u)" -eq 0 ] || SUDO="sudo"
      $SUDO update-alternatives --set "$lib-$multiarch" \
        "/usr/lib/$multiarch/openblas-serial/$lib"
      ;;
  esac
done

jobs=$(nproc 2>/dev/null || echo 2)
cmake --preset release >/dev/null
cmake --build --preset release -j "$jobs"
