#!/bin/sh
# One store, many processes: `deltamap sweep --shard K/N` run as concurrent
# plain processes makes the store one process makes (byte for byte); any
# number of processes may create one store at once; other sweeps are
# refused without touching it; a shard killed by SIGKILL resumes; `info
# --shards N` names the shards with work left; --shard slurm reads the
# job-array variables. Run by `make test` with DELTAMAP set.
set -u
DM=${DELTAMAP:-build/deltamap}
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }

# 11 x 9 x 3 points, 36 tiles, some unreachable and near-singular
GRID="x=-0.5:0.5:11,y=-0.4:0.4:9,z=-0.7:-0.5:3"
OPTS="--robot chen2018 --mesh 1,1 --modes 6 --tile 3,3,1 --progress none --threads 1 --method partial"
SW="$DM sweep $OPTS --grid $GRID"

$SW --out "$TMP/ref" >/dev/null || bad "reference sweep"

# same() A B: identical trees (every file's name and bytes)
same() { diff -r "$1" "$2" >/dev/null; }

# start() CMD...: run in the background, remember its pid
pids=""
start() { "$@" >>"$TMP/log" 2>&1 & pids="$pids $!"; }
# finish: wait for all, count exit codes into $codes ("0 0 2 ...")
finish() {
    codes=""
    for p in $pids; do wait "$p"; codes="$codes $?"; done
    pids=""
}

# 1. N = 1..4 shards at once, one store: byte-identical, complete, valid
for n in 1 2 3 4; do
    k=0
    while [ $k -lt $n ]; do start $SW --out "$TMP/s$n" --shard $k/$n; k=$((k + 1)); done
    finish
    case "$codes" in *[1-9]*) bad "$n shards: exit codes$codes"; cat "$TMP/log" ;; *) ok ;; esac
    if same "$TMP/ref" "$TMP/s$n"; then ok; else bad "$n shards differ from one process"; fi
    "$DM" info "$TMP/s$n" --shards $n >"$TMP/info" 2>&1
    if [ $? -eq 0 ] && grep -q "36 of 36 complete" "$TMP/info" && grep -q "checksums ok" "$TMP/info" &&
        grep -q "none of $n has work" "$TMP/info"; then ok; else bad "info on $n shards"; cat "$TMP/info"; fi
done

# 1b. the member engine too: 3 shards at once make the one process's store
$SW --method members --out "$TMP/mref" >/dev/null || bad "members reference sweep"
for k in 0 1 2; do start $SW --method members --out "$TMP/m3" --shard $k/3; done
finish
case "$codes" in *[1-9]*) bad "members shards: exit codes$codes"; cat "$TMP/log" ;; *) ok ;; esac
if same "$TMP/mref" "$TMP/m3"; then ok; else bad "members: 3 shards differ from one process"; fi

# 2. four processes at once, same arguments, no store yet: all succeed
for i in 1 2 3 4; do start $SW --out "$TMP/same"; done
finish
if [ "$codes" = " 0 0 0 0" ]; then ok; else bad "4 concurrent creators: exit codes$codes"; cat "$TMP/log"; fi
if same "$TMP/ref" "$TMP/same"; then ok; else bad "4 concurrent creators: store differs"; fi

# 3. four at once with four grids: one owns the store, three are refused
#    (exit 2, "another grid") and the owner's store is a correct one
: >"$TMP/log"
g1="x=-0.1:0.1:3,y=0,z=-0.5" g2="x=-0.1:0.1:4,y=0,z=-0.5" g3="x=-0.1:0.1:5,y=0,z=-0.5" g4="x=-0.1:0.1:6,y=0,z=-0.5"
for g in "$g1" "$g2" "$g3" "$g4"; do
    "$DM" sweep $OPTS --grid "$g" --out "$TMP/ref_$g" >/dev/null || bad "reference $g"
done
for g in "$g1" "$g2" "$g3" "$g4"; do start "$DM" sweep $OPTS --grid "$g" --out "$TMP/race"; done
finish
zeros=$(echo $codes | tr ' ' '\n' | grep -c '^0$')
twos=$(echo $codes | tr ' ' '\n' | grep -c '^2$')
refused=$(grep -c "holds a sweep of another grid" "$TMP/log")
if [ "$zeros" -eq 1 ] && [ "$twos" -eq 3 ] && [ "$refused" -eq 3 ]; then ok; else
    bad "4 grids at once: exit codes$codes, $refused refusals"; cat "$TMP/log"; fi
owner=$(sed -n 's/.*"grid": "\([^"]*\)".*/\1/p' "$TMP/race/zarr.json" | head -1)
if [ -n "$owner" ] && same "$TMP/ref_$owner" "$TMP/race"; then ok; else bad "owner's store ($owner) is not its sweep"; fi

# 4. a complete store and four other sweeps at once: all refused, nothing
#    of the store touched (no file changed, added, removed or rewritten)
cp -rp "$TMP/ref" "$TMP/owner"
touch "$TMP/marker"
sleep 1
for g in "$g1" "$g2" "$g3" "$g4"; do start "$DM" sweep $OPTS --grid "$g" --out "$TMP/owner"; done
finish
if [ "$codes" = " 2 2 2 2" ]; then ok; else bad "other grids on a store: exit codes$codes"; fi
if same "$TMP/ref" "$TMP/owner" && [ -z "$(find "$TMP/owner" -newer "$TMP/marker")" ]; then ok; else
    bad "a refused sweep touched the owner's store"; find "$TMP/owner" -newer "$TMP/marker" | head; fi

# 5. --replace given to four processes at once replaces another sweep's
#    store once; given again, it resumes the store it made (never replaces it)
cp -rp "$TMP/ref_$g1" "$TMP/forced"
: >"$TMP/log"
for k in 0 1 2 3; do start $SW --out "$TMP/forced" --shard $k/4 --replace; done
finish
if [ "$codes" = " 0 0 0 0" ] && same "$TMP/ref" "$TMP/forced"; then ok; else
    bad "4 x --replace: exit codes$codes"; cat "$TMP/log"; fi
$SW --out "$TMP/forced" --replace >"$TMP/out" 2>&1
if grep -q "(36 already done, 0 computed)" "$TMP/out"; then ok; else bad "--replace on its own sweep replaced it"; cat "$TMP/out"; fi

# 6. SIGKILL one of two shards mid-way: info names it; rerunning it resumes
for attempt in 1 2 3; do
    rm -rf "$TMP/kill"
    $SW --out "$TMP/kill" --shard 0/2 >/dev/null 2>&1 &
    p0=$!
    $SW --out "$TMP/kill" --shard 1/2 >/dev/null 2>&1 &
    p1=$!
    # kill when 1..6 of the 36 tiles are written (shard 1 has 18)
    want=$(($(od -An -N1 -tu1 /dev/urandom) % 6 + 1))
    while [ "$(find "$TMP/kill/status/c" -type f ! -name '*.tmp.*' 2>/dev/null | wc -l)" -lt $want ] &&
        kill -0 $p1 2>/dev/null; do sleep 0.02; done
    kill -9 $p1 2>/dev/null
    wait $p0
    rc0=$?
    wait $p1
    rc1=$?
    "$DM" info "$TMP/kill" --shards 2 >"$TMP/info"
    if [ $rc1 -eq 137 ] && grep -q "1 of 2 still have work: 1$" "$TMP/info" &&
        grep -q "sbatch --array=1 " "$TMP/info"; then ok; else
        bad "shard 1 killed after $want tiles: exit $rc1, info:"; cat "$TMP/info"; fi
    $SW --out "$TMP/kill" --shard 1/2 >/dev/null || bad "rerun of the killed shard"
    if [ $rc0 -eq 0 ] && same "$TMP/ref" "$TMP/kill"; then ok; else bad "kill+rerun differs (attempt $attempt, exit $rc0)"; fi
done

# 7. what dead writers left is removed, what live ones write is not: a
#    staging directory beside the store and a metadata temporary in it, of
#    a PID that is gone and of one that runs (this shell)
sh -c 'exit 0' &
dead=$!
wait $dead
host=$(hostname)
rm -rf "$TMP/left" && cp -rp "$TMP/ref" "$TMP/left"
for p in $dead $$; do
    mkdir -p "$TMP/left.tmp.$host.$p/status" && touch "$TMP/left/zarr.json.tmp.$host.$p"
    touch "$TMP/left/status/c/0/0/0.tmp.$host.$p" # beside a complete tile: left alone
done
rm "$TMP/left/frequencies_hz/c/1/1/1/0"
touch "$TMP/left/frequencies_hz/c/1/1/1/0.tmp.$host.$dead" # beside the missing chunk
$SW --out "$TMP/left" >"$TMP/out" 2>&1 || bad "sweep with leftovers"
if [ ! -e "$TMP/left.tmp.$host.$dead" ] && [ ! -e "$TMP/left/zarr.json.tmp.$host.$dead" ] &&
    [ ! -e "$TMP/left/frequencies_hz/c/1/1/1/0.tmp.$host.$dead" ] &&
    [ -d "$TMP/left.tmp.$host.$$" ] && [ -e "$TMP/left/zarr.json.tmp.$host.$$" ]; then ok; else
    bad "leftovers of dead writers kept, or a live writer's removed"; ls -a "$TMP" "$TMP/left"; fi
"$DM" info "$TMP/left" >"$TMP/info"
if grep -q "^temps   3 temporary files" "$TMP/info" && grep -q "(35 already done, 1 computed)" "$TMP/out"; then ok; else
    bad "info counts leftovers"; cat "$TMP/info" "$TMP/out"; fi
rm -rf "$TMP/left.tmp.$host.$$"

# 8. --shard slurm: the job-array variables, and clear errors without them
expect_err() { # CODE TEXT CMD... : exit CODE and TEXT on stderr
    code=$1 text=$2
    shift 2
    "$@" >/dev/null 2>"$TMP/err"
    rc=$?
    if [ $rc -eq "$code" ] && grep -qF -- "$text" "$TMP/err"; then ok; else
        bad "$*: exit $rc, expected $code with '$text'"; cat "$TMP/err"; fi
}
SL="SLURM_ARRAY_TASK_ID SLURM_ARRAY_TASK_MIN SLURM_ARRAY_TASK_MAX SLURM_ARRAY_TASK_COUNT"
expect_err 2 "SLURM_ARRAY_TASK_ID is not set" env -u SLURM_ARRAY_TASK_ID $SW --out "$TMP/sl" --shard slurm
expect_err 2 "SLURM_ARRAY_TASK_MIN is not set" env -u SLURM_ARRAY_TASK_MIN SLURM_ARRAY_TASK_ID=1 $SW --out "$TMP/sl" --shard slurm
expect_err 2 "SLURM_ARRAY_TASK_COUNT is not set" env -u SLURM_ARRAY_TASK_COUNT SLURM_ARRAY_TASK_ID=1 SLURM_ARRAY_TASK_MIN=1 $SW --out "$TMP/sl" --shard slurm
expect_err 2 "not 2 consecutive" env SLURM_ARRAY_TASK_ID=7 SLURM_ARRAY_TASK_MIN=3 SLURM_ARRAY_TASK_MAX=7 SLURM_ARRAY_TASK_COUNT=2 $SW --out "$TMP/sl" --shard slurm
expect_err 2 "SLURM_ARRAY_TASK_ID=4 is not a shard 0..3" env SLURM_ARRAY_TASK_ID=4 $SW --out "$TMP/sl" --shard slurm/4
expect_err 1 "--shard takes K/N" $SW --out "$TMP/sl" --shard 4/4
expect_err 1 "--shard takes K/N" $SW --out "$TMP/sl" --shard 1
expect_err 1 "--shard takes K/N" $SW --out "$TMP/sl" --shard -1/3
if [ ! -e "$TMP/sl" ]; then ok; else bad "a refused --shard wrote a store"; fi
# an array 1-3 (task ids relative to the first) and a rerun of task 2 of 3
for id in 1 2 3; do
    start env SLURM_ARRAY_TASK_ID=$id SLURM_ARRAY_TASK_MIN=1 SLURM_ARRAY_TASK_MAX=3 SLURM_ARRAY_TASK_COUNT=3 \
        $SW --out "$TMP/sl" --shard slurm
done
finish
if [ "$codes" = " 0 0 0" ] && same "$TMP/ref" "$TMP/sl"; then ok; else bad "--shard slurm: exit codes$codes"; fi
rm -rf "$TMP/sl/status/c/1"
"$DM" info "$TMP/sl" --shards 3 >"$TMP/info"
busy=$(sed -n 's/^shards .* still have work: //p' "$TMP/info")
# "0-2,5" -> "0 1 2 5"
expand() { for r in $(echo "$1" | tr ',' ' '); do seq "${r%-*}" "${r#*-}"; done; }
for k in $(expand "$busy"); do
    env SLURM_ARRAY_TASK_ID=$k SLURM_ARRAY_TASK_MIN=0 SLURM_ARRAY_TASK_MAX=2 SLURM_ARRAY_TASK_COUNT=1 \
        $SW --out "$TMP/sl" --shard slurm/3 >/dev/null || bad "--shard slurm/3 as task $k"
done
if [ -n "$busy" ] && same "$TMP/ref" "$TMP/sl"; then ok; else bad "rerun of shards '$busy' by slurm/3"; cat "$TMP/info"; fi

echo "shards: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
