#!/bin/sh
# End-to-end tests of `deltamap sweep` and the map store: real clients
# (zarr-python, xarray), a real SIGKILL and SIGINT, a corrupted tile, a
# refused mismatch, thread-count determinism, values == `deltamap modes`.
set -u
DM=${DELTAMAP:-build/deltamap}
PY=.venv/bin/python
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }

GRID="x=-0.45:0.45:19,y=-0.3:0.3:13,z=-0.62:-0.5:2"
SW="$DM sweep --robot chen2018 --grid $GRID --mesh 2,2 --modes 6 --tile 4,4,1 --progress none --method partial"

$SW --out "$TMP/ref" --threads 1 >/dev/null || bad "reference sweep"
$SW --out "$TMP/two" --threads 2 >/dev/null || bad "two-thread sweep"
if diff -r "$TMP/ref" "$TMP/two" >/dev/null; then ok; else bad "1 and 2 threads differ"; fi
# the thread count from the environment instead of --threads, BLAS threads too
for env in "OMP_NUM_THREADS=1" "OMP_NUM_THREADS=2" "OMP_NUM_THREADS=2 OPENBLAS_NUM_THREADS=2"; do
    rm -rf "$TMP/env"
    env $env $SW --out "$TMP/env" >/dev/null || bad "sweep with $env"
    if diff -r "$TMP/ref" "$TMP/env" >/dev/null; then ok; else bad "$env differs from --threads 1"; fi
done

# a grid across zheng2017's cluster of rod modes (169.6-170.1 Hz): tracked
# frequencies identical for any thread count, BLAS threading, environment
# and tile shape (each point starts from an anchor's seed and is tracked
# against that anchor, clusters as subspaces)
CG="x=-0.06:0.06:5,y=-0.06:0.06:5,z=-0.45:-0.35:3"
CSW="$DM sweep --robot zheng2017 --grid $CG --progress none --method partial"
$CSW --out "$TMP/c16" --tile 16,16,1 --threads 2 >/dev/null || bad "cluster sweep"
for run in "--tile 8,8,1 --threads 1" "--tile 2,3,1 --threads 2" "OMP_NUM_THREADS=1" "OMP_NUM_THREADS=2" "OPENBLAS_NUM_THREADS=2"; do
    rm -rf "$TMP/cx"
    case "$run" in
        --*) $CSW --out "$TMP/cx" $run >/dev/null ;;
        *) env $run $CSW --out "$TMP/cx" --tile 16,16,1 >/dev/null ;;
    esac || bad "cluster sweep $run"
    if $PY -c "
import sys, zarr, numpy as np
a, b = zarr.open('$TMP/c16', mode='r'), zarr.open('$TMP/cx', mode='r')
sys.exit(0 if all(np.array_equal(np.array(a[k]), np.array(b[k]), equal_nan=True)
                  for k in ('frequencies_tracked_hz', 'frequencies_hz', 'move_peak_m')) else 1)"; then ok; else bad "tracked arrays differ with $run"; fi
done

# real clients and values == deltamap modes
if $PY tests/check_store.py "$TMP/ref" "$DM" chen2018 2,2; then ok; else bad "zarr/xarray checks"; fi

# --method members: bit-identical for 1 and 2 threads, environments and
# tile shapes, across zheng2017's rod cluster too (families tracked by the
# reduced vectors' M-products); its values those of `deltamap modes` (the
# full model) as check_store.py holds them; a full store is not resumed by
# it. (Its families need not be the full sweep's: this grid's root, the
# home pose, has the platform's first pair exactly degenerate, and which
# basis of that pair the families start from is each solver's own.)
$SW --out "$TMP/mref" --threads 1 --method members >/dev/null || bad "members sweep"
$SW --out "$TMP/mtwo" --threads 2 --method members >/dev/null || bad "members sweep, 2 threads"
if diff -r "$TMP/mref" "$TMP/mtwo" >/dev/null; then ok; else bad "members: 1 and 2 threads differ"; fi
if $PY tests/check_store.py "$TMP/mref" "$DM" chen2018 2,2; then ok; else bad "members store checks"; fi
if "$DM" info "$TMP/mref" | grep -q "^model   mesh 2,2, 6 modes, standard moves, member bases"; then ok
else bad "info does not say the members made the store"; fi
if "$DM" info "$TMP/ref" | grep -q "^model   mesh 2,2, 6 modes, standard moves, the full model$"; then ok
else bad "info does not say the full model made the store"; fi
$CSW --out "$TMP/mc16" --tile 16,16,1 --threads 2 --method members >/dev/null || bad "members cluster sweep"
for run in "--tile 2,3,1 --threads 2" "OMP_NUM_THREADS=1" "OPENBLAS_NUM_THREADS=2"; do
    rm -rf "$TMP/mcx"
    case "$run" in
        --*) $CSW --out "$TMP/mcx" --method members $run >/dev/null ;;
        *) env $run $CSW --out "$TMP/mcx" --method members --tile 16,16,1 >/dev/null ;;
    esac || bad "members cluster sweep $run"
    if $PY -c "
import sys, zarr, numpy as np
a, b = zarr.open('$TMP/mc16', mode='r'), zarr.open('$TMP/mcx', mode='r')
sys.exit(0 if all(np.array_equal(np.array(a[k]), np.array(b[k]), equal_nan=True)
                  for k in ('frequencies_tracked_hz', 'frequencies_hz', 'move_peak_m')) else 1)"; then ok; else bad "members: arrays differ with $run"; fi
done
$SW --out "$TMP/mref" --method partial >/dev/null 2>"$TMP/err"
if [ $? -eq 2 ] && grep -q "another --method" "$TMP/err"; then ok; else bad "members store resumed by the full model"; cat "$TMP/err"; fi
# --method auto, the default (the same command without --method): a new
# store is the members' own, byte for byte; each store is resumed with the
# engine it was made with, nothing recomputed, and the output says which
AUTO="$DM sweep --robot chen2018 --grid $GRID --mesh 2,2 --modes 6 --tile 4,4,1 --progress none"
$AUTO --out "$TMP/auto" --threads 2 >"$TMP/out" || bad "auto sweep"
if grep -q "^engine  members (the member bases)$" "$TMP/out" &&
    diff -r "$TMP/mref" "$TMP/auto" >/dev/null; then ok; else bad "auto: not the members' store"; cat "$TMP/out"; fi
$AUTO --out "$TMP/ref" >"$TMP/out" 2>&1
if [ $? -eq 0 ] && grep -q "^engine  partial (the full model): the store being resumed was made with it$" "$TMP/out" &&
    grep -q "in 40 tiles (40 already done, 0 computed)" "$TMP/out"; then ok; else bad "auto: the full model's store not resumed as it is"; cat "$TMP/out"; fi
$AUTO --out "$TMP/mref" >"$TMP/out" 2>&1
if [ $? -eq 0 ] && grep -q "^engine  members" "$TMP/out" && grep -q "in 40 tiles (40 already done, 0 computed)" "$TMP/out"; then ok
else bad "auto: the members' store not resumed as it is"; cat "$TMP/out"; fi

# Interrupted sweeps need one that lasts: the sweep above is over in
# ~0.2 s, before a signal at a random moment would land. This one takes
# ~1.5 s on 2 threads; the signals come at fractions of its measured time
# (so on any machine), and each must find it running.
KSW="$DM sweep --robot chen2018 --grid x=-0.45:0.45:38,y=-0.3:0.3:26,z=-0.62:-0.5:4 --mesh 2,2 --modes 6 --tile 4,4,1 --progress none"
now_ms() { echo $(( $(date +%s%N) / 1000000 )); }
t0=$(now_ms)
$KSW --out "$TMP/kref" --threads 2 >/dev/null || bad "reference sweep for the interrupts"
span=$(( $(now_ms) - t0 ))
after() { # sleep $1 per cent of the reference's time
    sleep "$(awk -v s="$span" -v p="$1" 'BEGIN { printf "%.3f", s * p / 1e5 }')"
}

# SIGKILL at a random moment (10-70 % of the way), then resume: identical store
for attempt in 1 2 3; do
    rm -rf "$TMP/kill"
    $KSW --out "$TMP/kill" --threads 2 >/dev/null 2>&1 &
    pid=$!
    after $(( $(od -An -N1 -tu1 /dev/urandom) % 61 + 10 ))
    kill -9 $pid 2>/dev/null
    wait $pid 2>/dev/null
    rc=$?
    if [ $rc -eq 137 ]; then ok; else bad "SIGKILL found the sweep over (exit $rc, attempt $attempt)"; fi
    $KSW --out "$TMP/kill" >/dev/null || bad "resume after SIGKILL"
    if diff -r "$TMP/kref" "$TMP/kill" >/dev/null; then ok; else bad "kill+resume differs (attempt $attempt)"; fi
done

# SIGINT half-way: finishes tiles in flight, exits 7 with a resume hint, keeps them
rm -rf "$TMP/int"
$KSW --out "$TMP/int" --threads 2 >"$TMP/int.out" 2>"$TMP/int.err" &
pid=$!
after 50
kill -INT $pid
wait $pid
rc=$?
if [ $rc -eq 7 ] && grep -q "resume" "$TMP/int.err"; then ok; else bad "SIGINT exit $rc"; cat "$TMP/int.err"; fi
if ! ls "$TMP"/int/*/c/*/*/*.tmp.* >/dev/null 2>&1; then ok; else bad "temporary files after SIGINT"; fi
$KSW --out "$TMP/int" >/dev/null || bad "resume after SIGINT"
if diff -r "$TMP/kref" "$TMP/int" >/dev/null; then ok; else bad "interrupt+resume differs"; fi

# a corrupted tile is detected by info and recomputed by the next run
cp -r "$TMP/ref" "$TMP/bad"
printf 'XXXX' | dd of="$TMP/bad/frequencies_hz/c/2/1/0/0" bs=1 seek=16 conv=notrunc 2>/dev/null
"$DM" info "$TMP/bad" >"$TMP/info.out"
if [ $? -eq 5 ] && grep -q "1 corrupt" "$TMP/info.out"; then ok; else bad "info misses corruption"; cat "$TMP/info.out"; fi
if $PY -c "import zarr,sys; zarr.open_group('$TMP/bad')['frequencies_hz'][:]" 2>/dev/null; then
    bad "zarr read a corrupted chunk"; else ok; fi
$SW --out "$TMP/bad" >"$TMP/fix.out" || bad "repair run"
if grep -q "1 computed" "$TMP/fix.out" && diff -r "$TMP/ref" "$TMP/bad" >/dev/null; then ok; else bad "repair"; cat "$TMP/fix.out"; fi
"$DM" info "$TMP/bad" >"$TMP/info.out" && grep -q "checksums ok" "$TMP/info.out" && ok || bad "info after repair"

# every file around the data is checked on open (issue 38; the random
# damage of one file per round is tests/store_damage.py): an array's
# metadata with a value replaced and a coordinate chunk with a byte changed
# are named by info (exit 5), repaired by the resume and by info --repair
cp -r "$TMP/ref" "$TMP/meta"
sed -i 's/"units": "m\/N"/"units": "N\/m"/' "$TMP/meta/compliance_max/zarr.json"
printf 'Z' | dd of="$TMP/meta/y/c/0" bs=1 seek=9 conv=notrunc 2>/dev/null
"$DM" info "$TMP/meta" >"$TMP/info.out"
if [ $? -eq 5 ] && grep -q "damaged:  $TMP/meta/compliance_max/zarr.json: field 'attributes.units'" "$TMP/info.out" &&
    grep -q "damaged:  $TMP/meta/y/c/0: checksum mismatch" "$TMP/info.out" && grep -q "checksums FAILED" "$TMP/info.out"; then ok; else bad "info misses damaged metadata or coordinates"; cat "$TMP/info.out"; fi
cp -r "$TMP/meta" "$TMP/meta2"
$SW --out "$TMP/meta" >"$TMP/fix.out" || bad "resume of a store with damaged metadata"
if grep -q "repaired $TMP/meta/compliance_max/zarr.json" "$TMP/fix.out" && grep -q "repaired $TMP/meta/y/c/0" "$TMP/fix.out" &&
    diff -r "$TMP/ref" "$TMP/meta" >/dev/null; then ok; else bad "resume did not repair the metadata"; cat "$TMP/fix.out"; fi
"$DM" info --repair "$TMP/meta2" >"$TMP/info.out"
if [ $? -eq 0 ] && grep -q "repaired: $TMP/meta2/y/c/0" "$TMP/info.out" && diff -r "$TMP/ref" "$TMP/meta2" >/dev/null; then ok; else bad "info --repair"; cat "$TMP/info.out"; fi
# the group's metadata names the sweep: damaged, it is refused, not rewritten
cp -r "$TMP/ref" "$TMP/meta3"
sed -i 's/"title": "deltamap workspace maps"/"title": "maps"/' "$TMP/meta3/zarr.json"
cp -r "$TMP/meta3" "$TMP/meta4"
$SW --out "$TMP/meta3" >/dev/null 2>"$TMP/err"
if [ $? -eq 2 ] && grep -q "$TMP/meta3/zarr.json" "$TMP/err" && diff -r "$TMP/meta4" "$TMP/meta3" >/dev/null; then ok; else bad "damaged group metadata not refused"; cat "$TMP/err"; fi

# a trajectory run's store is checked the same way: info names a damaged
# array metadata file and a corrupt chunk (exit 5), --repair rewrites the
# metadata, and the run's store is otherwise left as it is
$DM trajectory --robot zheng2017 --path "pick:duration=0.2" --mesh 1,1 --modes 4 --no-reference --out "$TMP/run.zarr" >/dev/null || bad "trajectory --out .zarr"
"$DM" info "$TMP/run.zarr" >"$TMP/info.out"
if [ $? -eq 0 ] && grep -q "checksums ok" "$TMP/info.out" && grep -q "a trajectory run" "$TMP/info.out"; then ok; else bad "info on a trajectory store"; cat "$TMP/info.out"; fi
cp -r "$TMP/run.zarr" "$TMP/run0.zarr"
sed -i 's/"units": "m, rad"/"units": "mm"/' "$TMP/run.zarr/error/zarr.json"
printf 'Z' | dd of="$TMP/run.zarr/position/c/0/0" bs=1 seek=5 conv=notrunc 2>/dev/null
"$DM" info "$TMP/run.zarr" >"$TMP/info.out"
if [ $? -eq 5 ] && grep -q "damaged:  $TMP/run.zarr/error/zarr.json: field 'attributes.units'" "$TMP/info.out" &&
    grep -q "damaged:  $TMP/run.zarr/position/c/0/0: checksum mismatch" "$TMP/info.out"; then ok; else bad "info misses a damaged trajectory store"; cat "$TMP/info.out"; fi
"$DM" info --repair "$TMP/run.zarr" >/dev/null
cp "$TMP/run0.zarr/position/c/0/0" "$TMP/run.zarr/position/c/0/0"
if diff -r "$TMP/run0.zarr" "$TMP/run.zarr" >/dev/null && "$DM" info "$TMP/run.zarr" >/dev/null; then ok; else bad "info --repair of a trajectory store"; fi

# the group's record (what every other file is checked against) carries its
# own checksum: a value edited in it is named, and nothing is "repaired" to
# match it (the store damage fuzz found a trajectory's samples edited making
# info --repair rewrite every array's shape)
# edited_record SOURCE SED-EXPRESSION WHAT: SOURCE's group record edited;
# info --repair must exit 5 naming its checksum and change no file
edited_record() {
    rm -rf "$TMP/rec" "$TMP/rec-copy"
    cp -r "$1" "$TMP/rec"
    sed -i "$2" "$TMP/rec/zarr.json"
    cp -r "$TMP/rec" "$TMP/rec-copy"
    "$DM" info --repair "$TMP/rec" >"$TMP/info.out"
    if [ $? -eq 5 ] && grep -q "damaged:  $TMP/rec/zarr.json: attributes.deltamap fails its checksum" "$TMP/info.out" &&
        diff -r "$TMP/rec-copy" "$TMP/rec" >/dev/null; then ok; else bad "$3"; cat "$TMP/info.out"; fi
}
edited_record "$TMP/run0.zarr" 's/"samples": \([0-9]*\)/"samples": 9\1/' "an edited trajectory record"
edited_record "$TMP/ref" 's/"modes": 6,/"modes": 7,/' "an edited fingerprint"

# a store made by an older version: info reads it with a note, verifies its
# checksums; the resume refuses it and leaves it as it is
FIX=tests/fixtures/store-0.4.0
"$DM" info "$FIX" >"$TMP/info.out"
if [ $? -eq 0 ] && grep -q "made by version deltamap 0.4.0" "$TMP/info.out" && grep -q "checksums ok" "$TMP/info.out"; then ok; else bad "info on the 0.4.0 store"; cat "$TMP/info.out"; fi
cp -r "$FIX" "$TMP/old"
printf 'Z' | dd of="$TMP/old/x/c/0" bs=1 seek=2 conv=notrunc 2>/dev/null
"$DM" info "$TMP/old" >"$TMP/info.out"
if [ $? -eq 5 ] && grep -q "$TMP/old/x/c/0" "$TMP/info.out"; then ok; else bad "info misses a damaged coordinate of the 0.4.0 store"; cat "$TMP/info.out"; fi
rm -rf "$TMP/old" && cp -r "$FIX" "$TMP/old"
$DM sweep --robot zheng2017 --mesh 1,1 --modes 4 --no-dynamic --tile 2,1,1 --grid "x=-0.05:0.05:2,y=0,z=-0.4" --progress none --out "$TMP/old" >/dev/null 2>"$TMP/err"
if [ $? -eq 2 ] && grep -q "another version, made by deltamap 0.4.0" "$TMP/err" && diff -r "$FIX" "$TMP/old" >/dev/null; then ok; else bad "resume of the 0.4.0 store"; cat "$TMP/err"; fi

# another robot or grid is refused; --replace overwrites (--force, its old spelling, too)
$DM sweep --robot zheng2017 --grid "$GRID" --out "$TMP/ref" --progress none >/dev/null 2>"$TMP/err"
if [ $? -eq 2 ] && grep -q "another robot" "$TMP/err"; then ok; else bad "robot mismatch accepted"; fi
$DM sweep --robot chen2018 --grid "x=0,y=0,z=-0.5" --mesh 2,2 --modes 6 --tile 4,4,1 --out "$TMP/ref" --progress none >/dev/null 2>"$TMP/err"
if [ $? -eq 2 ] && grep -q "another grid" "$TMP/err"; then ok; else bad "grid mismatch accepted"; fi
$DM sweep --robot chen2018 --grid "x=0,y=0,z=-0.4" --out "$TMP/ref" --force --progress none >/dev/null 2>"$TMP/err" && ok || bad "--force"
if grep -q "^deltamap sweep: --force is deprecated: it is spelled --replace now$" "$TMP/err"; then ok; else bad "--force without its note"; cat "$TMP/err"; fi
$DM sweep --robot chen2018 --grid "x=0,y=0,z=-0.5" --out "$TMP/ref" --replace --progress none >/dev/null && ok || bad "--replace"
# the coupling index map (Zheng eq. 33) is the one-pose analysis's (JSON's
# 17 digits: 1e-15 relative)
C=$($DM modes --robot chen2018 --at 0,0,-0.5 --json | $PY -c "import json, sys; print(repr(json.load(sys.stdin)['coupling_index_log10']))")
if $PY -c "
import zarr, sys
v = float(zarr.open_group('$TMP/ref', mode='r')['coupling_index_log10'][0, 0, 0])
sys.exit(0 if abs(v - $C) <= 1e-15 * abs(v) and abs(v) > 100 else 1)"; then ok; else bad "coupling index map differs from modes ($C)"; fi
# its change against the nominal robot: 0 without effects; with a geometry
# error and a compliant actuator, modes' value at the pose (17 digits)
if $PY -c "
import zarr, sys
sys.exit(0 if float(zarr.open_group('$TMP/ref', mode='r')['coupling_index_change_log10'][0, 0, 0]) == 0 else 1)"; then ok; else bad "coupling change without effects is not 0"; fi
EFX="--set effects.error_rod_length=1e-4,0,-5e-5 --set effects.actuator_stiffness=2e4"
$DM sweep --robot chen2018 --grid "x=-0.02:0.02:2,y=0,z=-0.5" --mesh 1,1 --modes 4 --no-dynamic $EFX --out "$TMP/cchange" --progress none >/dev/null || bad "sweep with effects"
CC=$($DM modes --robot chen2018 --at 0.02,0,-0.5 --mesh 1,1 --modes 4 $EFX --json | $PY -c "import json, sys; print(repr(json.load(sys.stdin)['coupling_index_change_log10']))")
if $PY -c "
import zarr, sys
v = float(zarr.open_group('$TMP/cchange', mode='r')['coupling_index_change_log10'][1, 0, 0])
sys.exit(0 if abs(v - $CC) <= 1e-12 * max(abs(v), 1) and v != 0 else 1)"; then ok; else bad "coupling change map differs from modes ($CC)"; fi

# a sweep that implies days of work, or millions of files, is refused at once
$DM sweep --robot chen2018 --grid "x=-0.3:0.3:10000,y=-0.3:0.3:10000,z=-0.5" --tile 64,64,1 --threads 2 --out "$TMP/huge" 2>"$TMP/err"
if [ $? -eq 8 ] && grep -q "hours of work" "$TMP/err" && grep -q -- "--force-long runs it anyway" "$TMP/err" && [ ! -e "$TMP/huge" ]; then ok; else bad "days of work accepted"; cat "$TMP/err"; fi
$DM sweep --robot chen2018 --grid "x=-0.3:0.3:2000,y=-0.3:0.3:2000,z=-0.5" --tile 1,1,1 --no-dynamic --out "$TMP/huge" 2>"$TMP/err"
if [ $? -eq 8 ] && grep -q "chunk file per array and tile): about 8e+07 files (the limit is 2e+06): larger tiles" "$TMP/err" && [ ! -e "$TMP/huge" ]; then ok; else bad "millions of files accepted"; cat "$TMP/err"; fi

# bad grids are clear errors, nothing written
$DM sweep --robot chen2018 --grid "x=-0.3:0.3:0,y=0,z=-0.5" --out "$TMP/none" 2>"$TMP/err"
if [ $? -eq 2 ] && grep -q "N must be" "$TMP/err" && [ ! -e "$TMP/none" ]; then ok; else bad "bad grid"; fi
mkdir -p "$TMP/notastore" && touch "$TMP/notastore/file"
$DM sweep --robot chen2018 --grid "x=0,y=0,z=-0.5" --out "$TMP/notastore" 2>"$TMP/err"
if [ $? -eq 2 ] && grep -q "not a map store" "$TMP/err"; then ok; else bad "wrote into a foreign directory"; fi

# a cylindrical grid with unreachable points: masked, never fatal
$DM sweep --robot han2011 --grid "r=0:1.2:7,phi=0:300:6,z=0.9" --mesh 1,1 --modes 4 --no-dynamic --out "$TMP/cyl" --progress none >"$TMP/cyl.out" || bad "cylindrical sweep"
if grep -q "unreachable" "$TMP/cyl.out" && ! grep -q " 0 unreachable" "$TMP/cyl.out"; then ok; else bad "no unreachable points marked"; cat "$TMP/cyl.out"; fi
if $PY tools/plot_maps.py "$TMP/cyl" --out "$TMP/cylplots" >/dev/null && [ -s "$TMP/cylplots/f1.png" ] && [ -s "$TMP/cylplots/status.png" ]; then ok; else bad "plot_maps"; fi

# ---- tolerance maps (the Monte Carlo of `deltamap tolerance` per point) ----
TOLSET="--set effects.clearance=1e-5 --set effects.actuator_clearance_radial=2e-5"
TOLMC="--tol rod_length=5e-5 --tol theta_deg=0.02 --spec 6e-5"
TSW="$DM sweep --robot zheng2017 --grid x=-0.06:0.06:3,y=-0.06:0.06:3,z=-0.45:-0.35:2 --mesh 1,1 --modes 4 --no-dynamic --tile 2,2,1 --progress none $TOLSET"
$TSW --tolerance-samples 40 --tolerance-seed 5 $TOLMC --out "$TMP/t1" --threads 1 >/dev/null || bad "tolerance sweep"
$TSW --tolerance-samples 40 --tolerance-seed 5 $TOLMC --out "$TMP/t2" --threads 2 >/dev/null || bad "tolerance sweep, 2 threads"
if diff -r "$TMP/t1" "$TMP/t2" >/dev/null; then ok; else bad "tolerance maps: 1 and 2 threads differ"; fi
for k in 0 1; do
    $TSW --tolerance-samples 40 --tolerance-seed 5 $TOLMC --out "$TMP/ts" --shard $k/2 --threads 1 >/dev/null || bad "tolerance shard $k"
done
if diff -r "$TMP/t1" "$TMP/ts" >/dev/null; then ok; else bad "tolerance maps: shards differ"; fi
# a point's values are `deltamap tolerance` at its position (17 digits)
for ijk in "0 2 0" "2 1 1"; do
    set -- $ijk
    AT=$($PY -c "
import zarr
z = zarr.open_group('$TMP/t2', mode='r')
print(','.join(repr(float(z[a][int(i)])) for a, i in zip('xyz', '$ijk'.split())))")
    # shellcheck disable=SC2086
    "$DM" tolerance --robot zheng2017 --at "$AT" --mesh 1,1 --samples 40 --seed 5 $TOLMC $TOLSET --threads 2 --json >"$TMP/tol.json" || bad "tolerance at $AT"
    if $PY -c "
import json, sys, zarr
z = zarr.open_group('$TMP/t2', mode='r')
d = json.load(open('$TMP/tol.json'))
i, j, k = $1, $2, $3
pairs = [('error_mean_m', 'mean_error_m'), ('error_p95_m', 'p95_error_m'),
         ('error_max_m', 'max_error_m'), ('p_exceed_spec', 'p_exceed_spec')]
same = all(float(z[a][i, j, k]) == d[b] for a, b in pairs)
dom = z['dominant_source']
same = same and dom.attrs['source_names'][int(dom[i, j, k])] == d['dominant_source']
same = same and 0 < d['p_exceed_spec'] < 1 and d['mean_error_m'] > 0
sys.exit(0 if same else 1)"; then ok; else bad "tolerance map differs from deltamap tolerance at $AT"; fi
done
if $PY tools/plot_maps.py "$TMP/t1" --out "$TMP/tplots" >/dev/null && [ -s "$TMP/tplots/dominant_source.png" ] && [ -s "$TMP/tplots/p_exceed_spec.png" ] && [ -s "$TMP/tplots/error_p95_m.png" ]; then ok; else bad "plot_maps of tolerance maps"; fi
# the settings are the store's: another sample count (or none) is refused
$TSW --tolerance-samples 41 --tolerance-seed 5 $TOLMC --out "$TMP/t1" >/dev/null 2>"$TMP/err"
if [ $? -eq 2 ] && grep -q "tolerance Monte Carlo settings" "$TMP/err"; then ok; else bad "resume with other samples accepted"; cat "$TMP/err"; fi
$TSW --out "$TMP/t1" >/dev/null 2>"$TMP/err"
if [ $? -eq 2 ] && diff -r "$TMP/t1" "$TMP/t2" >/dev/null; then ok; else bad "resume without the Monte Carlo accepted"; fi
$TSW --tolerance-samples 40 --tolerance-seed 5 $TOLMC --out "$TMP/t1" >"$TMP/out" && grep -q "0 computed" "$TMP/out" && ok || bad "resume of a tolerance sweep"
# unreachable points stay marked; no spec, no p_exceed_spec
$DM sweep --robot zheng2017 --grid "x=-0.6:0.6:5,y=0,z=-0.4" --mesh 1,1 --modes 4 --no-dynamic --progress none --tolerance-samples 10 --tol arm_length=1e-4 --out "$TMP/tu" >/dev/null || bad "tolerance sweep with unreachable points"
if $PY -c "
import sys, zarr, numpy as np
z = zarr.open_group('$TMP/tu', mode='r')
s, e, d = (np.array(z[a]).ravel() for a in ('status', 'error_p95_m', 'dominant_source'))
sys.exit(0 if (s == 1).any() and np.isnan(e[s == 1]).all() and (d[s == 1] == -1).all()
         and np.isfinite(e[s == 0]).all() and (d[s == 0] >= 0).all() and 'p_exceed_spec' not in z else 1)"; then ok; else bad "unreachable points in tolerance maps"; fi
# bad input: clear errors naming the flag, before any work
for args in "--tolerance-samples 0:2:--tolerance-samples" "--tolerance-samples -5:2:--tolerance-samples" \
            "--tolerance-samples 5 --spec 0:2:--spec" "--tolerance-samples 5 --spec -1e-4:2:--spec" \
            "--tolerance-samples 5 --tol rod_length=-1e-5:2:--tol rod_length" \
            "--spec 1e-4:1:need --tolerance-samples" "--tolerance-samples 5000000 --threads 1:8:hours of work"; do
    a=${args%%:*}; rest=${args#*:}; want=${rest%%:*}; msg=${rest#*:}
    # shellcheck disable=SC2086
    timeout 10 $DM sweep --robot zheng2017 --grid "x=-0.05:0.05:200,y=0,z=-0.4" --progress none $a --out "$TMP/tbad" >/dev/null 2>"$TMP/err"
    rc=$?
    if [ $rc -eq "$want" ] && grep -q -- "$msg" "$TMP/err" && [ ! -e "$TMP/tbad" ]; then ok; else bad "sweep $a: exit $rc"; cat "$TMP/err"; fi
done

echo "store: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
