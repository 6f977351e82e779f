#!/bin/sh
# Install the Debian packages deltamap needs; skip what is present.
# Idempotent: a second run installs nothing and prints one line.
set -e
PKGS="build-essential pkg-config liblapacke-dev libopenblas-openmp-dev libsundials-dev
libcmocka-dev libinih-dev libjansson-dev libcminpack-dev python3"
missing=""
for p in $PKGS; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
        missing="$missing $p"
done
if [ -z "$missing" ]; then
    echo "deps: all Debian packages present"
    exit 0
fi
echo "deps: installing$missing"
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO=sudo
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
# shellcheck disable=SC2086
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
echo "deps: done"
