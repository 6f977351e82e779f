#!/bin/sh
# Run libFuzzer targets built by `make fuzz`, one after another:
#   tools/fuzz-run.sh SECONDS TARGET...
# Each starts from its seed corpus tests/fuzz/TARGET/ (read only) plus the
# inputs earlier runs found (build/fuzz-libfuzzer/corpus/TARGET/, where new
# inputs go); a crash, sanitizer report, leak or timeout is written to
# build/fuzz-libfuzzer/findings/TARGET/ and ends that target's run. The
# last lines of each log (executions, coverage, features) are printed.
# Add every finding to tests/fuzz/TARGET/ once it is fixed: `make test`
# replays them.
set -u
cd "$(dirname "$0")/.."
secs=${1:?usage: tools/fuzz-run.sh SECONDS TARGET...}
shift
D=build/fuzz-libfuzzer
status=0
for t in "$@"; do
    mkdir -p "$D/corpus/$t" "$D/findings/$t" "$D/logs"
    log="$D/logs/$t.log"
    dict=""
    [ -f "tests/fuzz/$t.dict" ] && dict="-dict=tests/fuzz/$t.dict"
    echo "fuzz: $t for $secs s (log $log)"
    start=$(date +%s)
    ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 \
        "$D/fuzz-$t" -max_total_time="$secs" -timeout=20 -rss_limit_mb=2048 -max_len=65536 \
            -print_final_stats=1 -artifact_prefix="$D/findings/$t/" $dict \
            "$D/corpus/$t" "tests/fuzz/$t" >"$log" 2>&1
    rc=$?
    end=$(date +%s)
    grep -E "^#[0-9]+.*(DONE|pulse|NEW|REDUCE)" "$log" | tail -1
    grep -E "stat::(number_of_executed_units|average_exec_per_sec|new_units_added|peak_rss_mb)" "$log"
    echo "fuzz: $t exit $rc after $((end - start)) s; findings: $(ls "$D/findings/$t" | wc -l)"
    [ "$rc" -eq 0 ] || status=1
done
exit $status
