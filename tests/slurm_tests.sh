#!/bin/sh
# A sweep as a job array on a real Slurm, started here on this one machine:
# munged, slurmctld and slurmd as plain processes with their own
# configuration, ports, state and sockets in a temporary directory (nothing
# of the system's Slurm, if any, is used or touched). The array's store
# must be byte-identical to one process's, every task must exit 0, and
# resubmitting (some or all tasks) must resume. Every daemon is stopped by
# its pid on exit. Without the Slurm packages or root the test is SKIPPED
# (exit 77), never passed. Run by `make test` with DELTAMAP set.
set -u
DM=${DELTAMAP:-build/deltamap}
SKIPPED=77
skip() { echo "slurm: SKIPPED: $*"; exit $SKIPPED; }
for b in munged mungekey munge slurmctld slurmd sbatch squeue sinfo scancel python3; do
    command -v $b >/dev/null 2>&1 || skip "$b not found (make deps installs slurmctld slurmd slurm-client munge)"
done
[ "$(id -u)" -eq 0 ] || skip "slurmd must run as root to start jobs"

pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
now() { date +%s.%N; }
since() { echo "$(now) $1" | awk '{ printf "%.1f", $1 - $2 }'; }

# nothing of a surrounding Slurm job may leak into ours
for v in $(env | sed -n 's/^\(SLURM_[A-Za-z0-9_]*\)=.*/\1/p'); do unset "$v"; done
TMP=$(mktemp -d)
chmod 755 "$TMP" # munged: every folder above its socket must be searchable by all
export SLURM_CONF="$TMP/slurm.conf"
munged_pid="" ctld_pid="" slurmd_pid=""
steps_before=$(pgrep -x slurmstepd | sort) # a system Slurm's, if any: not ours

# Stop in order: jobs (so slurmd leaves no step behind), then the daemons,
# each by the pid it was started with; then make sure none is left.
stop_pid() { # PID: TERM, up to 10 s, then KILL
    [ -n "$1" ] || return 0
    kill "$1" 2>/dev/null || return 0
    i=0
    while kill -0 "$1" 2>/dev/null && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    kill -9 "$1" 2>/dev/null
    wait "$1" 2>/dev/null
}
cleanup() {
    if [ -n "$ctld_pid" ] && kill -0 "$ctld_pid" 2>/dev/null; then
        scancel --quiet --user="$(id -un)" 2>/dev/null
        i=0
        while [ -n "$(squeue -h 2>/dev/null)" ] && [ $i -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
    fi
    stop_pid "$slurmd_pid"
    stop_pid "$ctld_pid"
    stop_pid "$munged_pid"
    # steps of finished jobs may take a moment to go; ours if new since the start
    i=0
    while :; do
        left=""
        for p in $munged_pid $ctld_pid $slurmd_pid; do kill -0 "$p" 2>/dev/null && left="$left $p"; done
        new_steps=$(pgrep -x slurmstepd | sort | comm -13 "$TMP/steps_before" - | tr '\n' ' ')
        [ -n "$left$new_steps" ] && [ $i -lt 50 ] || break
        sleep 0.1
        i=$((i + 1))
    done
    for p in $new_steps; do kill -9 "$p" 2>/dev/null; done # started by our slurmd
    rm -rf "$TMP"
    if [ -n "$left$new_steps" ]; then
        echo "FAIL: processes left running after 5 s:$left $new_steps"
        exit 1
    fi
}
echo "$steps_before" >"$TMP/steps_before"
trap cleanup EXIT
trap 'exit 1' INT TERM HUP

free_port() { python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }

# ---- MUNGE: its own key, and its socket in a folder of its own (0755) ----
mkdir -p "$TMP/munge" "$TMP/state" "$TMP/spool"
chmod 755 "$TMP/munge"
mungekey --create --keyfile="$TMP/munge.key" || skip "mungekey cannot create a key"
munged -F --socket="$TMP/munge/munge.socket" --key-file="$TMP/munge.key" \
    --pid-file="$TMP/munge/munged.pid" --seed-file="$TMP/munged.seed" \
    --log-file="$TMP/munged.log" >"$TMP/munged.out" 2>&1 &
munged_pid=$!
i=0
until munge -n -S "$TMP/munge/munge.socket" 2>/dev/null | unmunge -S "$TMP/munge/munge.socket" >/dev/null 2>&1; do
    i=$((i + 1))
    if [ $i -gt 100 ] || ! kill -0 $munged_pid 2>/dev/null; then
        bad "munged did not start"; cat "$TMP/munged.out"; exit 1
    fi
    sleep 0.1
done

# ---- a one-node cluster at 127.0.0.1 ----
host=$(hostname -s)
cat >"$SLURM_CONF" <<EOF
ClusterName=deltamap-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$TMP/munge/munge.socket
StateSaveLocation=$TMP/state
SlurmdSpoolDir=$TMP/spool
SlurmctldPidFile=$TMP/slurmctld.pid
SlurmdPidFile=$TMP/slurmd.pid
SlurmctldLogFile=$TMP/slurmctld.log
SlurmdLogFile=$TMP/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
JobCompType=jobcomp/filetxt
JobCompLoc=$TMP/jobcomp.txt
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
SchedulerType=sched/builtin
SchedulerParameters=batch_sched_delay=0
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MailProg=/bin/true
NodeName=$host NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
t0=$(now)
slurmctld -D -f "$SLURM_CONF" >"$TMP/slurmctld.out" 2>&1 &
ctld_pid=$!
slurmd -D -f "$SLURM_CONF" >"$TMP/slurmd.out" 2>&1 &
slurmd_pid=$!
i=0
until [ "$(sinfo -h -o %T 2>/dev/null)" = idle ]; do
    i=$((i + 1))
    if [ $i -gt 300 ]; then
        bad "the node is not idle after 30 s: $(sinfo -h -o %T 2>&1)"
        tail -5 "$TMP/slurmctld.log" "$TMP/slurmd.log" "$TMP/slurmctld.out" "$TMP/slurmd.out"
        exit 1
    fi
    sleep 0.1
done
echo "slurm: cluster idle after $(since "$t0") s"
ok

# ---- the sweep: one process, then as arrays ----
DMABS=$(cd "$(dirname "$DM")" && pwd)/$(basename "$DM")
ARGS="--robot chen2018 --mesh 1,1 --modes 6 --tile 3,3,1 --grid x=-0.5:0.5:11,y=-0.4:0.4:9,z=-0.7:-0.5:3"
"$DM" sweep $ARGS --threads 1 --progress none --out "$TMP/ref" >/dev/null || bad "reference sweep"

# submit SBATCH-OPTIONS...: submit the array job, wait for it by polling
# squeue, check every task's exit code in the job-completion log
submit() {
    t1=$(now)
    jid=$(sbatch --parsable --cpus-per-task=1 --chdir="$PWD" --output="$TMP/task-%A_%a.out" \
        "$@" tools/slurm/sweep.sbatch $ARGS --out "$TMP/store")
    [ -n "$jid" ] || { bad "sbatch $*"; return; }
    i=0
    while [ -n "$(squeue -h -j "$jid" 2>/dev/null)" ] && [ $i -lt 3000 ]; do sleep 0.1; i=$((i + 1)); done
    [ $i -lt 3000 ] || bad "job $jid still queued or running after 300 s"
    i=0 # the completion records follow the end of the job closely
    while [ "$(grep -c "ArrayJobId=$jid " "$TMP/jobcomp.txt" 2>/dev/null)" -lt "$ntasks" ] && [ $i -lt 100 ]; do
        sleep 0.1; i=$((i + 1))
    done
    done_ok=$(grep "ArrayJobId=$jid " "$TMP/jobcomp.txt" | grep "JobState=COMPLETED" | grep -c " ExitCode=0:0")
    echo "slurm: array $* ($ntasks tasks) finished in $(since "$t1") s, $done_ok exited 0"
    if [ "$done_ok" -eq "$ntasks" ]; then ok; else
        bad "array $*: $done_ok of $ntasks tasks completed with exit code 0"
        grep "ArrayJobId=$jid " "$TMP/jobcomp.txt"; cat "$TMP"/task-"$jid"_*.out
    fi
}
same() { if diff -r "$TMP/ref" "$TMP/store" >/dev/null; then ok; else bad "$1: the store differs from one process's"; fi; }

# 1. four shards as four array tasks (two at a time on two CPUs)
ntasks=4
submit --array=0-3 --export=ALL,DELTAMAP="$DMABS"
same "array 0-3"
"$DM" info "$TMP/store" --shards 4 >"$TMP/info"
if grep -q "36 of 36 complete" "$TMP/info" && grep -q "none of 4 has work" "$TMP/info"; then ok; else
    bad "info after the array"; cat "$TMP/info"; fi

# 2. lose two tiles; rerun just the tasks info names, as it says
rm "$TMP/store/status/c/0/0/1" "$TMP/store/frequencies_hz/c/3/2/2/0"
"$DM" info "$TMP/store" --shards 4 >"$TMP/info"
array=$(sed -n 's/^rerun   sbatch --array=\([0-9,-]*\) --export=ALL,SHARDS=4 .*/\1/p' "$TMP/info")
ntasks=$(for r in $(echo "$array" | tr ',' ' '); do seq "${r%-*}" "${r#*-}"; done | wc -l)
if [ -n "$array" ] && [ "$ntasks" -ge 1 ] && [ "$ntasks" -le 2 ]; then ok; else bad "info names no rerun"; cat "$TMP/info"; fi
[ -n "$array" ] && submit --array="$array" --export=ALL,DELTAMAP="$DMABS",SHARDS=4
same "rerun of tasks $array"

# 3. resubmit the whole array: every task finds its tiles done
ntasks=4
submit --array=0-3 --export=ALL,DELTAMAP="$DMABS"
same "resubmitted array"
n=$(grep -l "(9 already done, 0 computed)" "$TMP"/task-"$jid"_*.out 2>/dev/null | wc -l)
if [ "$n" -eq 4 ]; then ok; else bad "resubmitted tasks recomputed tiles ($n of 4 computed nothing)"; fi

echo "slurm: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
