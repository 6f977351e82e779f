#!/bin/sh
# Install what deltamap needs; skip what is present (idempotent: a second
# run installs nothing).
#  - Debian packages: compiler, LAPACKE + OpenBLAS (OpenMP build), SUNDIALS,
#    cmocka, libinih, jansson, cminpack
#  - for the Slurm test (tests/slurm_tests.sh), if they can be installed:
#    slurmctld, slurmd, slurm-client, munge. The test runs its own daemons
#    with its own configuration; nothing here configures or starts a
#    system-wide Slurm or MUNGE (their services stay stopped; without
#    /etc/slurm/slurm.conf Slurm's would not start anyway). Where they
#    cannot be installed the test reports SKIPPED.
#  - a Python virtual environment in .venv with numpy, matplotlib, zarr and
#    xarray for the plotting tools and the store-compatibility tests
set -e
cd "$(dirname "$0")/.."
PKGS="build-essential pkg-config liblapacke-dev libopenblas-openmp-dev libsundials-dev
libcmocka-dev libinih-dev libjansson-dev libcminpack-dev python3 python3-venv"
SLURM_PKGS="slurmctld slurmd slurm-client munge"
missing_of() {
    m=""
    for p in "$@"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || m="$m $p"
    done
    echo "$m"
}
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO=sudo
export DEBIAN_FRONTEND=noninteractive
# shellcheck disable=SC2086
missing=$(missing_of $PKGS)
# shellcheck disable=SC2086
slurm_missing=$(missing_of $SLURM_PKGS)
[ -z "$missing$slurm_missing" ] || $SUDO apt-get update -qq
if [ -n "$missing" ]; then
    echo "deps: installing Debian packages:$missing"
    # shellcheck disable=SC2086
    $SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
else
    echo "deps: Debian packages present"
fi
if [ -n "$slurm_missing" ]; then
    echo "deps: installing Debian packages for the Slurm test:$slurm_missing"
    # Their services are not to be started (the test runs daemons of its
    # own): a policy-rc.d that denies it, for this install only, unless the
    # system has one of its own.
    POLICY=/usr/sbin/policy-rc.d
    if [ ! -e $POLICY ]; then
        trap '$SUDO rm -f $POLICY' EXIT
        trap 'exit 1' INT TERM HUP
        printf '#!/bin/sh\nexit 101\n' | $SUDO tee $POLICY >/dev/null
        $SUDO chmod 755 $POLICY
    fi
    # shellcheck disable=SC2086
    $SUDO apt-get install -y -qq --no-install-recommends $slurm_missing >/dev/null ||
        echo "deps: could not install$slurm_missing: the Slurm test will be SKIPPED"
else
    echo "deps: Slurm test packages present"
fi
PYMODS="numpy matplotlib zarr xarray"
if .venv/bin/python -c "import numpy, matplotlib, zarr, xarray" 2>/dev/null; then
    echo "deps: Python environment .venv present"
else
    echo "deps: creating .venv with $PYMODS"
    python3 -m venv .venv
    .venv/bin/pip install -q --disable-pip-version-check $PYMODS
fi
