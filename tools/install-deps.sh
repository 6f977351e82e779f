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
#    xarray for the plotting tools and the store-compatibility tests, vtk
#    (VTK's own readers: the shapes tests read deltamap's .vtu back) and
#    plotly (tools/explore_maps.py), at the versions pinned in
#    tools/constraints.txt
#  - for the map explorer's browser test (tests/browser_tests.sh), if it can
#    be installed: chromium (headless); where it cannot, the test says SKIPPED
# `tools/install-deps.sh --fuzz` installs only what `make fuzz` needs
# besides: clang with its sanitizer and libFuzzer runtimes, LLVM's OpenMP.
set -e
cd "$(dirname "$0")/.."
if [ "${1:-}" = "--fuzz" ]; then
    PKGS="clang-14 libclang-rt-14-dev libomp-14-dev"
else
    PKGS="build-essential pkg-config liblapacke-dev libopenblas-openmp-dev libsundials-dev
libcmocka-dev libinih-dev libjansson-dev libcminpack-dev python3 python3-venv"
    SLURM_PKGS="slurmctld slurmd slurm-client munge"
    BROWSER_PKGS="chromium"
fi
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
slurm_missing=$(missing_of ${SLURM_PKGS:-})
# shellcheck disable=SC2086
browser_missing=$(missing_of ${BROWSER_PKGS:-})
[ -z "$missing$slurm_missing$browser_missing" ] || $SUDO apt-get update -qq
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
elif [ "${1:-}" != "--fuzz" ]; then
    echo "deps: Slurm test packages present"
fi
if [ -n "$browser_missing" ]; then
    echo "deps: installing Debian packages for the browser test:$browser_missing"
    # shellcheck disable=SC2086
    $SUDO apt-get install -y -qq --no-install-recommends $browser_missing >/dev/null ||
        echo "deps: could not install$browser_missing: the browser test will be SKIPPED"
elif [ "${1:-}" != "--fuzz" ]; then
    echo "deps: browser test package present"
fi
[ "${1:-}" = "--fuzz" ] && exit 0
PYMODS="numpy matplotlib zarr xarray vtk plotly"
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
