#!/bin/sh
# The per-pose paths allocate nothing: a sweep's points and a trajectory's
# steps reuse their thread's workspaces (docs/architecture.md). Every heap
# allocation of the process, in every library (OpenBLAS, LAPACKE, SUNDIALS,
# libgomp), is counted by an LD_PRELOAD shim (tests/count_alloc.c), and a
# run with 4x the points per tile, or twice the steps, must make exactly as
# many as the smaller run. (LAPACKE's row-major calls and OpenBLAS's
# non-transposed dgemm inside a parallel region allocated at every call;
# the all-modes trajectory reference, a dense dsygvd per step kept as a
# check, still allocates inside LAPACK and is left out here.) Run by
# `make test` with DELTAMAP and ALLOC_SHIM set; the sanitizers bring their
# own allocator, so under SANITIZE=1 (no ALLOC_SHIM) it is SKIPPED.
set -u
DM=${DELTAMAP:-build/deltamap}
SHIM=${ALLOC_SHIM:-}
if [ -z "$SHIM" ]; then
    echo "alloc tests: SKIPPED (no ALLOC_SHIM: the sanitizer build counts nothing)"
    exit 0
fi
case $SHIM in /*) ;; *) SHIM=$PWD/$SHIM ;; esac
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
pass=0
fail=0

# allocations DESCRIPTION ARGS...: run deltamap under the shim, print the count
allocations() {
    DM_ALLOC_REPORT=$TMP/count LD_PRELOAD=$SHIM "$DM" "$@" >/dev/null 2>"$TMP/err" ||
        { echo "FAIL: deltamap $*"; cat "$TMP/err"; echo 0; return; }
    cat "$TMP/count"
}
same() { # DESCRIPTION A B
    if [ "$2" -eq "$3" ] && [ "$2" -gt 0 ]; then
        pass=$((pass + 1))
    else
        fail=$((fail + 1))
        echo "FAIL: $1: $2 allocations for the small run, $3 for the large one"
    fi
}

# sweeps: 2 tiles of 16 x 16 points, then 2 of 32 x 32 (the anchor lattice
# is 16 x 16 both times), on 2 threads, three robots (their subspaces
# differ: 16 to 27 vectors)
for robot in chen2018 zheng2017 han2011; do
    for g in 16 32; do
        rm -rf "$TMP/s"
        eval "n$g=\$(allocations sweep --robot $robot --grid x=-0.15:0.15:$g,y=-0.15:0.15:$((2 * g)),z=-0.5 \
            --tile $g,$g,1 --threads 2 --method partial --progress none --out $TMP/s)"
    done
    same "sweep $robot" "$n16" "$n32"
done

# the member engine's sweeps, with and without the standard moves
for moves in "" "--no-dynamic"; do
    for g in 16 32; do
        rm -rf "$TMP/s"
        eval "m$g=\$(allocations sweep --robot zheng2017 --grid x=-0.15:0.15:$g,y=-0.15:0.15:$((2 * g)),z=-0.45 \
            --tile $g,$g,1 --threads 2 --progress none --method members $moves --out $TMP/s)"
    done
    same "members sweep $moves" "$m16" "$m32"
done

# trajectories: 50 and 100 steps, CVODE and closed form
for integ in cvode closed-form; do
    for d in 0.05 0.1; do
        eval "t_$(echo $d | tr . _)=\$(allocations trajectory --robot chen2018 --integrator $integ \
            --path 'circle:centre=0,0,-0.45;radius=0.05;rate=10;duration=$d' --no-reference \
            --out $TMP/t.csv)"
    done
    same "trajectory $integ" "$t_0_05" "$t_0_1"
done

echo "alloc tests: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
