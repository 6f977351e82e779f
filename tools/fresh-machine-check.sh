#!/bin/sh
# Fresh-machine check: does the README's promise hold on a bare Debian 12?
#
#   sudo tools/fresh-machine-check.sh [WORKDIR]      (root: debootstrap, chroot, mount)
#
# Makes a minimal Debian 12 (debootstrap --variant=minbase bookworm, what a
# container starts from) in a temporary directory (under WORKDIR, default
# /var/tmp), clones this repository's HEAD into it as /root/deltamap, and
# runs the README's set-up commands there verbatim, as root, in a chroot
# with a clean environment:
#     the bare-system line (apt-get update && apt-get install -y make git),
#     make demo, make test
# It prints how long each took and PASS/FAIL, then unmounts and removes
# everything it made (also when interrupted). Rerunnable; not part of make
# test. It downloads about 400 MB (Debian packages, the Python wheels) and
# takes 15-30 minutes on 2 cores.
#
# Needs: root with CAP_SYS_ADMIN (mount of proc, a bind mount of /dev, a
# tmpfs on /dev/shm; a container without it cannot run this), network
# access to a Debian mirror and to PyPI, git and debootstrap (installed from
# Debian if missing). The mirror is the host's (first URIs of
# /etc/apt/sources.list.d/*.sources or first deb line of sources.list;
# MIRROR=... overrides). Where the host reaches PyPI through a TLS proxy
# with its own CA (pip's cert setting or PIP_CERT), that CA bundle is
# copied in and named by PIP_CERT inside the chroot: the network of the
# host, not a package of the machine under test; nothing else of the host
# enters the chroot.
set -eu
REPO=$(cd "$(dirname "$0")/.." && pwd)
BASE=${1:-/var/tmp}
[ "$(id -u)" -eq 0 ] || { echo "fresh-machine-check: run as root (debootstrap, chroot, mount)" >&2; exit 1; }

if [ -z "${MIRROR:-}" ]; then
    MIRROR=$(sed -n 's/^URIs: *\([^ ]*\).*/\1/p' /etc/apt/sources.list.d/*.sources 2>/dev/null |
             grep -m1 '/debian$' || true)
    [ -n "$MIRROR" ] || MIRROR=$(awk '$1 == "deb" && $2 ~ /debian$/ {print $2; exit}' \
                                 /etc/apt/sources.list 2>/dev/null || true)
    [ -n "$MIRROR" ] || MIRROR=http://deb.debian.org/debian
fi
for tool in debootstrap git; do
    command -v $tool >/dev/null || {
        echo "fresh-machine-check: installing $tool on the host"
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $tool >/dev/null
    }
done

# the README's commands, verbatim (the check fails if the README lost them)
readme_line() {
    line=$(grep -m1 "^    $1" "$REPO/README.md" | sed 's/^    //') ||
        { echo "fresh-machine-check: README.md has no line '    $1'" >&2; exit 1; }
    printf '%s\n' "$line"
}
SETUP=$(readme_line "apt-get update && apt-get install -y make git")
DEMO=$(readme_line "make demo")
TEST=$(readme_line "make test")

ROOT=$(mktemp -d "$BASE/dm-fresh-XXXXXX")
cleanup() {
    for m in dev/shm dev/pts dev proc; do
        mountpoint -q "$ROOT/$m" 2>/dev/null && umount "$ROOT/$m"
    done
    # never follow into a mount that is still there
    if ! grep -q " $ROOT/" /proc/mounts; then rm -rf "$ROOT"; else
        echo "fresh-machine-check: $ROOT still has mounts; not removed" >&2; fi
}
trap cleanup EXIT
trap 'exit 130' INT TERM

now() { date +%s; }
echo "fresh-machine-check: $(date -u '+%Y-%m-%d %H:%M UTC'), commit $(git -C "$REPO" rev-parse --short HEAD), mirror $MIRROR, in $ROOT"
t0=$(now)
debootstrap --variant=minbase bookworm "$ROOT" "$MIRROR" >"$ROOT.debootstrap.log" 2>&1 || {
    tail -20 "$ROOT.debootstrap.log"; rm -f "$ROOT.debootstrap.log"; exit 1; }
rm -f "$ROOT.debootstrap.log"
t1=$(now)
echo "debootstrap minbase bookworm: $((t1 - t0)) s"

mount -t proc proc "$ROOT/proc"
mount --bind /dev "$ROOT/dev" && mount --make-private "$ROOT/dev"
mount --bind /dev/pts "$ROOT/dev/pts" && mount --make-private "$ROOT/dev/pts"
mount -t tmpfs -o size=1g tmpfs "$ROOT/dev/shm"
cp /etc/resolv.conf "$ROOT/etc/resolv.conf"
git clone -q "$REPO" "$ROOT/root/deltamap"
git -C "$ROOT/root/deltamap" checkout -q "$(git -C "$REPO" rev-parse HEAD)"

ENVS="HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8"
cert=${PIP_CERT:-$(pip3 config get global.cert 2>/dev/null || sed -n 's/^cert *= *//p' /etc/pip.conf 2>/dev/null || true)}
if [ -n "$cert" ] && [ -f "$cert" ]; then
    cp "$cert" "$ROOT/root/host-network-ca.crt"
    ENVS="$ENVS PIP_CERT=/root/host-network-ca.crt"
    echo "(host network: pip uses the host's CA bundle $cert)"
fi

status=PASS
step() { # name, command
    s=$(now)
    # shellcheck disable=SC2086
    if chroot "$ROOT" /usr/bin/env -i $ENVS /bin/sh -c "cd /root/deltamap && $2" \
            >"$ROOT/step.log" 2>&1; then r=ok; else r=FAILED; status=FAIL; fi
    e=$(now)
    echo "$1: $r in $((e - s)) s"
    [ "$r" = ok ] || tail -40 "$ROOT/step.log"
    tail -3 "$ROOT/step.log" | sed 's/^/    | /'
    [ "$r" = ok ]
}
step "$SETUP" "$SETUP" && step "$DEMO" "$DEMO" && step "$TEST" "$TEST" || true
echo "fresh-machine-check: $status ($(( $(now) - t0 )) s in all)"
[ "$status" = PASS ]
