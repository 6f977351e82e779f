#!/bin/sh
# The kernels' instruction-set paths (include/dm_isa.h) end to end: every
# path this CPU has gives byte-identical stores and trajectories, on 1 and
# 2 threads, for the three presets; DELTAMAP_ISA names the path, a bad
# one is refused before any work; `deltamap --version` names the CPU and
# the path. (The unit tests run under each path too: `make unit-tests`.)
set -u
DM=${DELTAMAP:-build/deltamap}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }

paths=$($DM --version | sed -n 's/^paths on this CPU: //p')
case " $paths " in *" default "*) ok ;; *) bad "--version lists no default path: '$paths'" ;; esac
for isa in $paths; do
    out=$(DELTAMAP_ISA=$isa $DM --version)
    if echo "$out" | grep -q "^kernels: $isa (" && echo "$out" | grep -q "^CPU: ."; then ok
    else bad "DELTAMAP_ISA=$isa: --version says '$out'"; fi
done
best=$($DM --version | sed -n 's/^kernels: \([a-z0-9]*\) .*/\1/p')
last=$(echo "$paths" | awk '{print $NF}')
if [ "$best" = "$last" ]; then ok; else bad "unset DELTAMAP_ISA runs $best, not the best ($last)"; fi

# refused before any work, naming the variable and the paths there are
for want in avx3 neon sse4; do
    DELTAMAP_ISA=$want $DM sweep --robot chen2018 --grid "x=0,y=0,z=-0.5" --out "$TMP/bad" \
        --progress none >/dev/null 2>"$TMP/err"
    rc=$?
    if [ $rc -eq 2 ] && grep -q "DELTAMAP_ISA=$want: unknown path" "$TMP/err" &&
        grep -q "available here: default" "$TMP/err" && [ ! -e "$TMP/bad" ]; then ok
    else bad "DELTAMAP_ISA=$want: exit $rc, $(cat "$TMP/err")"; fi
done
for isa in avx2 avx512; do # a path this CPU lacks (where it does)
    case " $paths " in *" $isa "*) continue ;; esac
    DELTAMAP_ISA=$isa $DM modes --robot chen2018 >/dev/null 2>"$TMP/err"
    rc=$?
    if [ $rc -eq 2 ] && grep -q "this CPU or build has no $isa path" "$TMP/err"; then ok
    else bad "DELTAMAP_ISA=$isa on a CPU without it: exit $rc"; fi
done

# stores byte for byte: every path, 1 and 2 threads, against the baseline
# path on one thread (tiles of 4 x 4: a store of several chunks per array)
sweep() { # preset grid path threads out (the full model; the members' below)
    DELTAMAP_ISA=$3 $DM sweep --robot "$1" --grid "$2" --tile 4,4,1 --threads "$4" \
        --method partial --progress none --out "$5" >/dev/null
}
for spec in "chen2018 x=-0.3:0.3:9,y=-0.3:0.3:7,z=-0.6:-0.45:2" \
            "zheng2017 x=-0.06:0.06:7,y=-0.06:0.06:5,z=-0.45:-0.35:2" \
            "han2011 x=-0.1:0.1:7,y=-0.1:0.1:5,z=-0.75:-0.65:2"; do
    preset=${spec%% *}
    grid=${spec#* }
    sweep "$preset" "$grid" default 1 "$TMP/$preset-ref" || bad "$preset sweep (default, 1 thread)"
    for isa in $paths; do
        for th in 1 2; do
            [ "$isa" = default ] && [ $th = 1 ] && continue
            rm -rf "$TMP/$preset-x"
            sweep "$preset" "$grid" "$isa" $th "$TMP/$preset-x" || bad "$preset sweep ($isa, $th)"
            if diff -r "$TMP/$preset-ref" "$TMP/$preset-x" >/dev/null; then ok
            else bad "$preset store on path $isa, $th thread(s), differs from default's"; fi
        done
    done
done

# the member engine's store: the same bytes on every path (its own code
# is BLAS, LAPACK and scalar loops; the moves' kernels are per path)
mgrid="x=-0.1:0.1:6,y=-0.1:0.1:5,z=-0.45:-0.35:2"
for isa in $paths; do
    DELTAMAP_ISA=$isa $DM sweep --robot zheng2017 --grid "$mgrid" --tile 4,4,1 --threads 2 \
        --method members --progress none --out "$TMP/members-$isa" >/dev/null ||
        bad "members sweep on $isa"
    if diff -r "$TMP/members-default" "$TMP/members-$isa" >/dev/null; then ok
    else bad "members store on path $isa differs from default's"; fi
done

# a trajectory's CSV and JSON, every path
for isa in $paths; do
    DELTAMAP_ISA=$isa $DM trajectory --robot zheng2017 --path zheng2017 --no-reference \
        --out "$TMP/traj-$isa.csv" --json >"$TMP/traj-$isa.json" || bad "trajectory on $isa"
    if cmp -s "$TMP/traj-default.csv" "$TMP/traj-$isa.csv" &&
        cmp -s "$TMP/traj-default.json" "$TMP/traj-$isa.json"; then ok
    else bad "zheng2017 trajectory on path $isa differs from default's"; fi
done

echo "isa: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
