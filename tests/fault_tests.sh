#!/bin/sh
# Fault injection, as SQLite does it: the n-th allocation fails, or the disk
# fills up, during a sweep, a resume, `trajectory --out` (CSV and Zarr),
# `diagnose --write-robot`, `modes --vtk` and `trajectory --vtk` (its frames
# and .pvd). Every case must end with a clear message and
# exit 6 (out of memory) or 5 (i/o error), no crash and no sanitizer report,
# no temporary file left and no half-written output (every file present is
# byte-identical to the undisturbed run's), and a rerun without the fault
# must give output byte-identical to the undisturbed run.
#
#  1. allocation failure: FAULT_DELTAMAP (tests/fault_alloc.c, deltamap
#     linked with --wrap=malloc,calloc,realloc; jansson's allocations too)
#     with DM_FAIL_ALLOC=n: the n-th allocation and all later ones fail;
#  2. write failure: FAULT_SHIM (tests/fault_write.c, LD_PRELOAD) with
#     DM_FAIL_IO=n: the n-th write/pwrite/fsync/fflush/fclose/rename on a
#     regular file and all later ones fail with ENOSPC;
#  3. a real full disk: a small tmpfs mounted here (root only; SKIPPED with
#     a message where mount is not permitted), filled to the brim or sized
#     to run out part way, then grown (remount) for the rerun.
# n runs over every value up to FAULT_FIRST, the last FAULT_LAST before the
# run succeeds (where outputs are written) and FAULT_MID evenly spaced ones
# between (deterministic), then the first n that injects nothing (the run
# must succeed). Run by `make test` with DELTAMAP, FAULT_DELTAMAP, FAULT_SHIM.
set -u
set -f # the specs below hold ';' and '*' nowhere, but never glob them
DM=${DELTAMAP:-build/deltamap}
FDM=${FAULT_DELTAMAP:-build/tests/deltamap-faultinj}
SHIM=${FAULT_SHIM:-build/tests/fault_write.so}
case $SHIM in /*) ;; *) SHIM=$PWD/$SHIM ;; esac
FIRST=${FAULT_FIRST:-8}
MID=${FAULT_MID:-12}
LAST=${FAULT_LAST:-8}
# memory-backed when possible: these runs write and remove many small files
if [ -d /dev/shm ] && [ -w /dev/shm ]; then W=$(mktemp -d /dev/shm/dm-fault-XXXXXX); else W=$(mktemp -d); fi
MNT=$W/mnt
cleanup() {
    mountpoint -q "$MNT" 2>/dev/null && umount "$MNT"
    rm -rf "$W"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
# a sanitizer report is exit 86, never mistaken for an error code; leaks of a
# run that failed for want of memory are not counted (the process ends)
SAN="exitcode=86:detect_leaks=0:verify_asan_link_order=0"
pass=0
fail=0
cases=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }

# ---- the scenarios: arguments, with $RUN the directory of their outputs ---
GRID="x=-0.05:0.05:2,y=-0.05:0.05:2,z=-0.5"
PATHSPEC="p2p:from=0,0,-0.5;to=0.01,0,-0.5;duration=0.004"
args() { # scenario -> deltamap arguments
    case $1 in
    sweep | resume) echo "sweep --robot chen2018 --grid $GRID --mesh 1,1 --modes 2 --tile 1,2,1 --threads 1 --progress none --out $RUN/s" ;;
    csv) echo "trajectory --robot chen2018 --path $PATHSPEC --mesh 1,1 --modes 2 --out $RUN/t.csv" ;;
    zarr) echo "trajectory --robot chen2018 --path $PATHSPEC --mesh 1,1 --modes 2 --out $RUN/t.zarr" ;;
    robot) echo "diagnose --measured $W/modal.csv --mesh 1,1 --threads 1 --no-pairs --write-robot $RUN/fixed.ini" ;;
    vtu) echo "modes --robot chen2018 --mesh 1,1 --modes 2 --vtk $RUN/m.vtu" ;;
    pvd) echo "trajectory --robot chen2018 --path $PATHSPEC --mesh 1,1 --modes 2 --no-reference --vtk $RUN/frames --vtk-every 2" ;;
    esac
}
output() { case $1 in sweep | resume) echo s ;; csv) echo t.csv ;; zarr) echo t.zarr ;; robot) echo fixed.ini ;;
    vtu) echo m.vtu ;; pvd) echo frames ;; esac; }
setup() { # scenario: the state before the run, in $RUN
    mkdir -p "$RUN"
    find "$RUN" -mindepth 1 -delete
    [ "$1" = resume ] && cp -r "$W/partial" "$RUN/s"
    [ "$1" = pvd ] && mkdir "$RUN/frames" # --vtk DIR must exist
    return 0
}

# ---- checks ------------------------------------------------------------------
# every file of the output that exists is the undisturbed run's, byte for byte
no_half_written() { # scenario what
    out=$RUN/$(output "$1")
    tmps=$(find "$RUN" -name '*.tmp.*' | head -3)
    [ -z "$tmps" ] || { bad "$2: temporary files left: $tmps"; return 1; }
    [ -e "$out" ] || return 0
    if [ "$1" = zarr ] && ! diff -r "$out" "$W/ref/$1" >/dev/null 2>&1; then
        bad "$2: half-written $(output "$1") (a run's store is whole or absent)"
        return 1
    elif [ -d "$out" ]; then # a sweep's store: resumable, every file whole
        (cd "$out" && find . -type f) | while read -r f; do
            cmp -s "$out/$f" "$W/ref/$1/$f" || { echo "$f"; break; }
        done >"$W/differ"
        [ -s "$W/differ" ] && { bad "$2: half-written or stray file $(output "$1")/$(cat "$W/differ")"; return 1; }
    elif ! cmp -s "$out" "$W/ref/$1"; then
        bad "$2: half-written $(output "$1")"
        return 1
    fi
    return 0
}
same_as_reference() { # scenario what
    if diff -r "$RUN/$(output "$1")" "$W/ref/$1" >/dev/null 2>&1; then ok; else bad "$2: rerun differs from the undisturbed run"; fi
}
# one faulty run: kind (alloc|io|disk), scenario, n, expected exit code
check_case() {
    kind=$1 sc=$2 n=$3 want=$4 rc=$5
    what="$kind $sc n=$n"
    cases=$((cases + 1))
    read -r total injected <"$W/report" 2>/dev/null || injected=1
    if [ "$rc" -ge 128 ] || [ "$rc" -eq 86 ]; then
        bad "$what: crashed (exit $rc)"
        tail -5 "$W/err"
        return
    fi
    if [ "$injected" = 0 ]; then # the run never reached the fault: it must succeed
        [ "$rc" -eq 0 ] && ok || { bad "$what: no fault injected, exit $rc"; cat "$W/err"; }
        no_half_written "$sc" "$what" && same_as_reference "$sc" "$what"
        return
    fi
    if [ "$rc" -eq "$want" ] && grep -q "^deltamap: .*$6" "$W/err"; then
        ok
    elif [ "$rc" -eq 0 ] && no_half_written "$sc" "$what" && [ -e "$RUN/$(output "$sc")" ]; then
        ok # the failure was absorbed and the output is complete and right
    else
        bad "$what: exit $rc (expected $want and a message with '$6')"
        cat "$W/err"
    fi
    no_half_written "$sc" "$what" && ok
}
# the values of n: 1..FIRST, MID spaced, the LAST before N, then N + 1
samples() {
    awk -v N="$1" -v F="$FIRST" -v M="$MID" -v L="$LAST" 'BEGIN {
        for (n = 1; n <= N + 1; n++) {
            if (n <= F || n > N - L || n == N + 1) { print n; continue }
            for (i = 1; i <= M; i++) if (n == int(F + i * (N - L - F) / (M + 1))) { print n; break }
        }
    }'
}
rerun() { # scenario what: the same command without a fault
    $DM $(args "$1") >/dev/null 2>"$W/err2" || { bad "$2: rerun failed: $(cat "$W/err2")"; return; }
    same_as_reference "$1" "$2"
}

# ---- references: every scenario undisturbed --------------------------------
RUN=$W/run
mkdir -p "$W/ref"
$DM synth --robot zheng2017 --kind modal --effect payload_mass=1.5 --noise 0.02 --poses 6 \
    --modes 2 --seed 4 --mesh 1,1 --out "$W/modal.csv" >/dev/null || bad "synth"
SCENARIOS="sweep resume csv zarr robot vtu pvd"
for sc in $SCENARIOS; do
    if [ "$sc" = resume ]; then # the sweep's store, one tile missing
        rm -rf "$W/partial" && cp -r "$W/ref/sweep" "$W/partial"
        find "$W/partial" -path '*/c/1/0/0*' -type f -exec rm {} +
    fi
    setup $sc
    $DM $(args $sc) >/dev/null 2>"$W/err" || { bad "undisturbed $sc: $(cat "$W/err")"; continue; }
    cp -r "$RUN/$(output $sc)" "$W/ref/$sc"
done
[ "$fail" -eq 0 ] || { echo "fault: $pass passed, $fail failed"; exit 1; }
cmp -s "$W/ref/sweep/status/c/1/0/0" "$W/ref/resume/status/c/1/0/0" && ok || bad "resume reference"

# ---- 1. allocation failure at the n-th allocation ---------------------------
for sc in $SCENARIOS; do
    setup $sc
    DM_FAIL_REPORT=$W/report $FDM $(args $sc) >/dev/null 2>&1
    read -r N _ <"$W/report"
    list=$(samples "$N")
    echo "fault: alloc $sc: $N allocations, $(echo $list | wc -w) cases"
    for n in $list; do
        setup $sc
        rm -f "$W/report"
        ASAN_OPTIONS=$SAN UBSAN_OPTIONS=$SAN DM_FAIL_ALLOC=$n DM_FAIL_REPORT=$W/report \
            $FDM $(args $sc) >/dev/null 2>"$W/err"
        check_case alloc $sc $n 6 $? "out of memory"
        case $sc in sweep | resume | zarr) rerun $sc "alloc $sc n=$n" ;; esac
    done
    rerun $sc "alloc $sc"
done

# ---- 2. write failure from the n-th write/flush/close/rename on ------------
for sc in $SCENARIOS; do
    setup $sc
    DM_FAIL_REPORT=$W/report LD_PRELOAD=$SHIM ASAN_OPTIONS=$SAN $DM $(args $sc) >/dev/null 2>&1
    read -r N _ <"$W/report"
    list=$(samples "$N")
    echo "fault: write $sc: $N i/o calls, $(echo $list | wc -w) cases"
    for n in $list; do
        setup $sc
        rm -f "$W/report"
        LD_PRELOAD=$SHIM ASAN_OPTIONS=$SAN UBSAN_OPTIONS=$SAN DM_FAIL_IO=$n DM_FAIL_REPORT=$W/report \
            $DM $(args $sc) >/dev/null 2>"$W/err"
        check_case io $sc $n 5 $? "No space left on device"
        rerun $sc "io $sc n=$n"
    done
done

# ---- 3. a full disk: a small tmpfs -------------------------------------------
mkdir -p "$MNT"
if ! mount -t tmpfs -o size=4k tmpfs "$MNT" 2>/dev/null; then
    echo "fault: SKIPPED full-disk cases: cannot mount a tmpfs here (needs root with CAP_SYS_ADMIN)"
else
    umount "$MNT"
    RUN=$MNT
    for sc in $SCENARIOS; do
        # the output's size on tmpfs (pages), from a run that fits
        mount -t tmpfs -o size=64m tmpfs "$MNT"
        setup $sc
        base=$(du -sk "$MNT" | cut -f1)
        $DM $(args $sc) >/dev/null 2>&1
        full=$(du -sk "$MNT" | cut -f1)
        umount "$MNT"
        # no room at all (a filler takes it), then room for part of the output
        sizes="0 $(awk -v b="$base" -v f="$full" 'BEGIN { for (k = 1; k <= 4; k++) {
            s = b + int((f - b) * k / 5 / 4) * 4; if (s > b) print s } }' | sort -un)"
        for kb in $sizes; do
            if [ "$kb" -eq 0 ]; then opt=size=$(((base + 4) * 1024)); else opt=size=$((kb * 1024)); fi
            mount -t tmpfs -o "$opt" tmpfs "$MNT"
            setup $sc
            [ "$kb" -eq 0 ] && dd if=/dev/zero of="$MNT/filler" bs=4k count=1 2>/dev/null
            ASAN_OPTIONS=$SAN UBSAN_OPTIONS=$SAN $DM $(args $sc) >/dev/null 2>"$W/err"
            rc=$?
            echo "0 1" >"$W/report"
            [ "$rc" -eq 0 ] && echo "0 0" >"$W/report" # it fitted after all
            check_case disk $sc "${kb}k" 5 $rc "No space left on device"
            rm -f "$MNT/filler"
            mount -o remount,size=64m "$MNT"
            rerun $sc "disk $sc ${kb}k"
            umount "$MNT"
        done
        echo "fault: disk $sc: tmpfs of $(echo $sizes | sed 's/\([0-9]*\)/\1k/g; s/^0k/full/')"
    done
fi

echo "fault: $cases fault cases; $pass passed, $fail failed"
[ "$fail" -eq 0 ]
