#!/bin/sh
# Install what deltamap needs; skip what is present (idempotent: a second
# run installs nothing).
#  - Debian packages: compiler, LAPACKE + OpenBLAS (OpenMP build), SUNDIALS,
#    cmocka, libinih, jansson, cminpack
#  - a Python virtual environment in .venv with numpy, matplotlib, zarr and
#    xarray for the plotting tools and the store-compatibility tests
set -e
cd "$(dirname "$0")/.."
PKGS="build-essential pkg-config liblapacke-dev libopenblas-openmp-dev libsundials-dev
libcmocka-dev libinih-dev libjansson-dev libcminpack-dev python3 python3-venv"
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
PYMODS="numpy matplotlib zarr xarray"
if .venv/bin/python -c "import numpy, matplotlib, zarr, xarray" 2>/dev/null; then
    echo "deps: Python environment .venv present"
else
    echo "deps: creating .venv with $PYMODS"
    python3 -m venv .venv
    .venv/bin/pip install -q --disable-pip-version-check $PYMODS
fi
