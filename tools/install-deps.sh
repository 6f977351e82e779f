#!/bin/sh
# Install what deltamap needs; skip what is present (idempotent: a second
# run installs nothing).
#  - Debian packages: compiler, LAPACKE + OpenBLAS (OpenMP build), SUNDIALS,
#    cmocka, libinih, jansson, cminpack
#  - a Python virtual environment in .venv with numpy, matplotlib, zarr and
#    xarray for the plotting tools and the store-compatibility tests, at the
#    versions pinned in tools/constraints.txt
# `tools/install-deps.sh --fuzz` installs only what `make fuzz` needs
# besides: clang with its sanitizer and libFuzzer runtimes, LLVM's OpenMP.
set -e
cd "$(dirname "$0")/.."
if [ "${1:-}" = "--fuzz" ]; then
    PKGS="clang-14 libclang-rt-14-dev libomp-14-dev"
else
    PKGS="build-essential pkg-config liblapacke-dev libopenblas-openmp-dev libsundials-dev
libcmocka-dev libinih-dev libjansson-dev libcminpack-dev python3 python3-venv"
fi
missing=""
for p in $PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
        missing="$missing $p"
done
if [ -n "$missing" ]; then
    echo "deps: installing Debian packages:$missing"
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO=sudo
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    # shellcheck disable=SC2086
    $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
else
    echo "deps: Debian packages present"
fi
[ "${1:-}" = "--fuzz" ] && exit 0
PYMODS="numpy matplotlib zarr xarray"
# present, and each pinned package at its pinned version (a second run
# installs nothing; a .venv made before the pins were moved is brought in line)
pinned() {
    .venv/bin/python - tools/constraints.txt <<'PY' 2>/dev/null
import sys
from importlib.metadata import version
import numpy, matplotlib, zarr, xarray
for line in open(sys.argv[1]):
    line = line.split("#")[0].strip()
    if line:
        name, want = line.split("==")
        if version(name) != want:
            sys.exit(1)
PY
}
if pinned; then
    echo "deps: Python environment .venv present (pinned versions)"
else
    echo "deps: installing $PYMODS into .venv (versions of tools/constraints.txt)"
    [ -x .venv/bin/python ] || python3 -m venv .venv
    .venv/bin/pip install -q --disable-pip-version-check -c tools/constraints.txt $PYMODS
fi
