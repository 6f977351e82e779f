#!/bin/sh
# Sweep throughput of one process with T threads against T shards of one
# thread each, run at once into one store (the two ways to use T cores).
#
#   tools/shard_bench.sh [THREADS] [GRID] [EXTRA SWEEP OPTIONS...]
#
# Defaults: 2 threads, chen2018 at the default mesh on a 24 x 24 grid (the
# grid of `make bench`). Prints poses/s of each (wall time of the whole
# command, anchors and store included) and the CPU time spent (user +
# system, all processes: what the shards' duplicated anchors cost), and
# checks that both stores are byte-identical. The wall times mean something
# only on an otherwise idle machine. DELTAMAP names the binary (default
# build/deltamap).
set -eu
DM=${DELTAMAP:-build/deltamap}
T=${1:-2}
[ $# -eq 0 ] || shift
GRID=${1:-x=-0.3:0.3:24,y=-0.3:0.3:24,z=-0.5}
[ $# -eq 0 ] || shift
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
SW="$DM sweep --robot chen2018 --grid $GRID --progress none $*"
now() { date +%s.%N; }
points=$(echo "$GRID" | tr ',' '\n' | awk -F: '{ n = (NF == 3 ? $3 : 1); p = (NR == 1 ? n : p * n) } END { print p }')

# cpu FILE CMD...: run CMD, append its user + system seconds to FILE
cpu() {
    f=$1
    shift
    /usr/bin/time -f "%U %S" -o "$f.one" "$@" >/dev/null
    cat "$f.one" >>"$f"
}
t0=$(now)
cpu "$TMP/cpu1" $SW --threads "$T" --out "$TMP/threads"
t1=$(now)
k=0
pids=""
while [ $k -lt "$T" ]; do
    cpu "$TMP/cpu$k.s" $SW --threads 1 --shard "$k/$T" --out "$TMP/shards" &
    pids="$pids $!"
    k=$((k + 1))
done
for p in $pids; do wait "$p"; done
t2=$(now)
c1=$(awk '{ s += $1 + $2 } END { print s }' "$TMP/cpu1")
c2=$(cat "$TMP"/cpu*.s | awk '{ s += $1 + $2 } END { print s }')
echo "$t0 $t1 $t2 $points $T $c1 $c2" | awk '{
    printf "1 process x %d threads: %7.1f poses/s (%.2f s wall, %.2f s CPU)\n", $5, $4 / ($2 - $1), $2 - $1, $6
    printf "%d shards x 1 thread:   %7.1f poses/s (%.2f s wall, %.2f s CPU)\n", $5, $4 / ($3 - $2), $3 - $2, $7 }'
if diff -r "$TMP/threads" "$TMP/shards" >/dev/null; then echo "stores byte-identical"; else
    echo "stores DIFFER"; exit 1; fi
