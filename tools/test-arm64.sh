#!/bin/sh
# Cross-build deltamap for aarch64 and run its tests under qemu-user on this
# (x86-64, Debian 12) machine: `make test-arm64`; docs/arm64.md.
#
#   tools/test-arm64.sh [--no-deps] [--no-cli] [--jobs N] [--skip "T ..."]
#
#  1. deps   the project's own packages (tools/install-deps.sh), then Debian's
#            cross compiler, qemu-user and the arm64 builds of the libraries
#            through multiarch (dpkg --add-architecture arm64); idempotent: a
#            second run installs nothing. --no-deps skips this stage.
#  2. build  the project's Makefile, its variables overridden on the command
#            line (CC, AR, BUILD=build/arm64, PKG_CONFIG, SUNDIALS_LIBS):
#            build/arm64/libdeltamap.a, build/arm64/deltamap and every
#            build/arm64/tests/test_*; each checked to be an AArch64 ELF.
#  3. unit   each unit test under qemu-aarch64 and every kernel path the
#            arm64 binary lists (NEON's default), single-threaded BLAS and
#            OpenMP as `make unit-tests` runs them, N at a time (--jobs,
#            the number of cores), the longest of the last run first; a
#            failure does not stop the others. --skip "test_a test_b" leaves
#            those out, reported as skipped.
#  4. cli    tests/cli_tests.sh with DELTAMAP a wrapper that runs the arm64
#            binary under qemu-aarch64 (--no-cli skips it).
#
# A unit test still running after ARM64_TEST_TIMEOUT seconds (10800) is
# stopped and counted as failed. Each stage's wall time is printed; the last
# lines are the summary, and the exit status is non-zero if any stage failed.
# Logs: build/arm64/logs/ (a test's: T.PATH.log).
#
# libsundials-dev:arm64 cannot be installed beside the amd64 packages: it
# depends on gfortran, mpi-default-dev, petsc-dev, libhypre-dev and cmake of
# its own architecture, and gfortran:arm64 conflicts with gfortran:amd64
# (neither is Multi-Arch: same). Only the two runtime libraries the project
# links are installed for arm64 (libsundials-cvode6, libsundials-nvecserial6,
# Multi-Arch: same, so of the amd64 packages' version); the headers are those
# of libsundials-dev (amd64) in /usr/include, identical file for file to the
# arm64 package's at 6.4.1+dfsg1-3, and the libraries are linked by their
# file names (SUNDIALS_LIBS), as no arm64 libsundials_*.so link exists.
set -u
cd "$(dirname "$0")/.."
ROOT=$(pwd)
SELF=$ROOT/tools/test-arm64.sh

TRIPLET=aarch64-linux-gnu
BUILD=build/arm64
LOGS=$BUILD/logs
# No -L /usr/aarch64-linux-gnu (QEMU_LD_PREFIX): the dynamic loader would be
# the cross package's (libc6-arm64-cross, 2.36-8cross1) while the loader's
# multiarch search path finds libc.so.6 of libc6:arm64 (2.36-9+deb12u14),
# which every arm64 library package depends on; a loader and a libc of two
# builds, and the first pthread_create (an OpenMP team) hangs for ever.
# Without a prefix qemu runs the binary's /lib/ld-linux-aarch64.so.1, that of
# libc6:arm64, and every library comes from the multiarch packages.
unset QEMU_LD_PREFIX
QEMU=qemu-aarch64
TEST_TIMEOUT=${ARM64_TEST_TIMEOUT:-10800}

now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

# one unit test under one kernel path (run by the unit stage, N at a time):
# its log, a one-line result file "passed|FAILED SECONDS", a line on stdout
if [ "${1:-}" = --run-one ]; then
    t=$2 isa=$3 log=$LOGS/$2.$3.log
    t1=$(now)
    DELTAMAP_ISA=$isa OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 timeout "$TEST_TIMEOUT" \
        $QEMU "$BUILD/tests/$t" >"$log" 2>&1
    rc=$?
    s=$(since "$t1")
    if [ "$rc" -eq 0 ]; then
        echo "passed $s" >"$log.res"
        echo "unit: $t ($isa) passed in $s s ($(grep -E '^\[  PASSED  \]' "$log" | tr -s ' '))"
    else
        echo "FAILED $s" >"$log.res"
        what="exit $rc"
        [ "$rc" -ne 124 ] || what="stopped after $TEST_TIMEOUT s"
        # one write, not interleaved with another test's line
        printf '%s\n%s\n' "unit: $t ($isa) FAILED ($what) in $s s:" \
            "$(grep -vE '^\[ +(RUN|OK) +\]|^\[=+\]' "$log" | head -40 | sed 's/^/    /')"
    fi
    exit 0
fi

DEPS=1
CLI=1
JOBS=$(nproc 2>/dev/null || echo 2)
SKIP=""
while [ $# -gt 0 ]; do
    case $1 in
        --no-deps) DEPS=0 ;;
        --no-cli) CLI=0 ;;
        --jobs) JOBS=$2; shift ;;
        --skip) SKIP=$2; shift ;;
        -h | --help) sed -n '2,37p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "test-arm64: unknown option $1 (see --help)" >&2; exit 2 ;;
    esac
    shift
done

LIBDIR=/usr/lib/$TRIPLET
SUNDIALS="$LIBDIR/libsundials_cvode.so.6 $LIBDIR/libsundials_nvecserial.so.6"
HOST_PKGS="gcc-$TRIPLET libc6-dev-arm64-cross qemu-user"
ARM_PKGS="pkgconf:arm64 liblapacke-dev:arm64 libopenblas-openmp-dev:arm64
libsundials-cvode6:arm64 libsundials-nvecserial6:arm64 libcmocka-dev:arm64
libinih-dev:arm64 libjansson-dev:arm64 libcminpack-dev:arm64"
TESTS=$(for f in tests/test_*.c; do basename "$f" .c; done)

summary=""
failed=""
stage_done() { # NAME START RESULT
    t=$(since "$2")
    echo "== arm64 $1: $3 in $t s"
    summary="$summary $1 $3 in ${t} s;"
    case $3 in ok* | *" 0 failed"* | skipped*) ;; *) failed="$failed $1" ;; esac
}
finish() {
    echo "== arm64 summary:${summary%;}"
    if [ -n "$failed" ]; then
        echo "test-arm64: FAILED:$failed (logs in $LOGS/)"
        exit 1
    fi
    echo "test-arm64: all passed"
    exit 0
}
mkdir -p "$LOGS"

# ---- 1. deps -------------------------------------------------------------
missing_of() {
    m=""
    for p in "$@"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || m="$m $p"
    done
    echo "$m"
}
if [ "$DEPS" = 1 ]; then
    t0=$(now)
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO=sudo
    export DEBIAN_FRONTEND=noninteractive
    res=ok
    tools/install-deps.sh || res="failed (tools/install-deps.sh)"
    if [ "$res" = ok ]; then
        updated=0
        if ! dpkg --print-foreign-architectures | grep -qx arm64; then
            echo "deps: adding the arm64 architecture (dpkg --add-architecture arm64)"
            $SUDO dpkg --add-architecture arm64
            $SUDO apt-get update -qq
            updated=1
        fi
        # shellcheck disable=SC2086
        missing=$(missing_of $HOST_PKGS $ARM_PKGS)
        if [ -n "$missing" ]; then
            [ "$updated" = 1 ] || $SUDO apt-get update -qq
            echo "deps: installing for arm64:$missing"
            # apt's own messages kept: a multiarch conflict is named there
            # shellcheck disable=SC2086
            $SUDO apt-get install -y -qq --no-install-recommends $missing \
                >"$LOGS/apt.log" 2>&1 || { cat "$LOGS/apt.log"; res="failed (apt-get install:$missing)"; }
        else
            echo "deps: arm64 cross toolchain, qemu-user and arm64 libraries present"
        fi
    fi
    stage_done deps "$t0" "$res"
    [ "$res" = ok ] || finish
fi
# the headers of libsundials-dev (amd64) serve the arm64 libraries: one version
hv=$(dpkg-query -W -f='${Version}' libsundials-dev 2>/dev/null)
av=$(dpkg-query -W -f='${Version}' libsundials-cvode6:arm64 2>/dev/null)
if [ -z "$hv" ] || [ "$hv" != "$av" ]; then
    echo "test-arm64: SUNDIALS headers (libsundials-dev '$hv') and arm64 library" \
        "(libsundials-cvode6:arm64 '$av') differ or are missing: run without --no-deps" >&2
    summary=" deps failed (SUNDIALS versions);"
    failed=" deps"
    finish
fi

# ---- 2. build ------------------------------------------------------------
t0=$(now)
TEST_BIN=$(for t in $TESTS; do printf '%s ' "$BUILD/tests/$t"; done)
echo "build: make -j$JOBS CC=$TRIPLET-gcc AR=$TRIPLET-ar BUILD=$BUILD PKG_CONFIG=$TRIPLET-pkg-config" \
    "SUNDIALS_LIBS=\"$SUNDIALS\" $BUILD/deltamap $BUILD/tests/test_* ($(echo $TESTS | wc -w) tests;" \
    "log: $LOGS/build.log)"
# shellcheck disable=SC2086
if make -j"$JOBS" CC=$TRIPLET-gcc AR=$TRIPLET-ar BUILD=$BUILD PKG_CONFIG=$TRIPLET-pkg-config \
    SUNDIALS_LIBS="$SUNDIALS" $BUILD/deltamap $TEST_BIN >"$LOGS/build.log" 2>&1; then
    res=ok
    for f in $BUILD/deltamap $TEST_BIN; do
        if ! $TRIPLET-readelf -h "$f" 2>/dev/null | grep -q "Machine:.*AArch64"; then
            echo "build: $f is not an AArch64 executable"
            res="failed (not AArch64)"
        fi
    done
    w=$(grep -c "warning:" "$LOGS/build.log")
    [ "$w" -eq 0 ] || { grep "warning:" "$LOGS/build.log"; res="$res, $w compiler warnings"; }
else
    tail -40 "$LOGS/build.log"
    res=failed
fi
stage_done build "$t0" "$res"
case $res in ok*) ;; *) finish ;; esac

# ---- 3. unit tests -------------------------------------------------------
t0=$(now)
# the deltamap a unit test runs (test_shape reads `modes --json`): the arm64
# binary under qemu, as the CLI stage runs it
WRAP=$BUILD/deltamap-qemu
printf '#!/bin/sh\nexec %s "%s" "$@"\n' "$QEMU" "$ROOT/$BUILD/deltamap" >"$WRAP"
chmod 755 "$WRAP"
export DELTAMAP="$ROOT/$WRAP"
$QEMU $BUILD/deltamap --version | sed 's/^/unit: /'
# every kernel path the binary has here, as `make unit-tests` (aarch64: default)
PATHS=$($QEMU $BUILD/deltamap --version 2>/dev/null | sed -n 's/^paths on this CPU: //p' | tr -d ,)
[ -n "$PATHS" ] || PATHS=default
runs=""
skipped=0
for t in $TESTS; do
    for isa in $PATHS; do
        case " $SKIP " in *" $t "*) skipped=$((skipped + 1)); continue ;; esac
        rm -f "$LOGS/$t.$isa.log.res.new"
        [ ! -f "$LOGS/$t.$isa.log.res" ] || mv "$LOGS/$t.$isa.log.res" "$LOGS/$t.$isa.log.res.last"
        runs="$runs $t:$isa"
    done
done
[ "$skipped" -eq 0 ] || echo "unit: skipped (--skip): $SKIP"
# the longest of the last run first (an unknown one first of all), N at a time
for r in $runs; do
    t=${r%:*} isa=${r#*:}
    last=$(awk '{ print $2 }' "$LOGS/$t.$isa.log.res.last" 2>/dev/null)
    echo "${last:-1e9} $t $isa"
done | sort -gr | awk '{ print $2, $3 }' | xargs -n 2 -P "$JOBS" "$SELF" --run-one
pass=0
fail=0
for r in $runs; do
    t=${r%:*} isa=${r#*:}
    case $(cat "$LOGS/$t.$isa.log.res" 2>/dev/null) in
        passed*) pass=$((pass + 1)) ;;
        *) fail=$((fail + 1)); echo "unit: FAIL: $t ($isa), log $LOGS/$t.$isa.log" ;;
    esac
done
rm -f "$LOGS"/*.res.last
res="$pass passed, $fail failed"
[ "$skipped" -eq 0 ] || res="$res, $skipped skipped"
stage_done unit "$t0" "$res"

# ---- 4. CLI tests --------------------------------------------------------
if [ "$CLI" = 1 ]; then
    t0=$(now)
    DELTAMAP=$WRAP tests/cli_tests.sh >"$LOGS/cli.log" 2>&1
    grep -A3 "^FAIL" "$LOGS/cli.log" | sed 's/^/    /'
    res=$(tail -1 "$LOGS/cli.log")
    case $res in "cli: "*) res=${res#cli: } ;; *) res="failed (no summary; see $LOGS/cli.log)" ;; esac
    stage_done cli "$t0" "$res"
else
    summary="$summary cli skipped;"
fi
finish
