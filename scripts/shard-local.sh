#!/usr/bin/env bash
# Run a config as N shards on one machine, each a separate `trace-bench run --shard K/N`
# process, then merge them: what scripts/slurm/sweep.sbatch does on a cluster, for users
# without one and for CI.
#
#   scripts/shard-local.sh CONFIG N [OUT] [-- RUN OPTIONS...]
#
# OUT defaults to results/<config stem>/sharded; shard K writes OUT/shard-K, the merge OUT/merged.
# At most JOBS shards run at once (default N; JOBS=1 runs them one after another). A shard
# that fails or is interrupted is rerun alone with the same command plus --resume; set
# RESUME=1 to pass --resume to every shard that has begun. TRACE_BENCH (default: trace-bench on PATH, else
# target/release/trace-bench) is the binary. Each shard's log is OUT/shard-K.log and its wall
# time is printed when it ends.
set -euo pipefail

if [ $# -lt 2 ]; then
    sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
config=$1
n=$2
shift 2
out="results/$(basename "${config%.toml}")/sharded"
if [ $# -gt 0 ] && [ "$1" != "--" ]; then
    out=$1
    shift
fi
[ "${1:-}" = "--" ] && shift
case $n in '' | *[!0-9]* | 0) echo "error: N must be a positive whole number, got '$n'" >&2; exit 2 ;; esac

bin=${TRACE_BENCH:-}
if [ -z "$bin" ]; then
    if command -v trace-bench >/dev/null; then bin=trace-bench; else bin=target/release/trace-bench; fi
fi
jobs=${JOBS:-$n}
mkdir -p "$out"

run_shard() {
    local k=$1 t0 rc resume=()
    shift
    # --resume where the shard has begun (a shard that never started runs afresh).
    [ "${RESUME:-0}" = 1 ] && [ -f "$out/shard-$k/results.csv" ] && resume=(--resume)
    t0=$(date +%s%N)
    rc=0
    "$bin" run "$config" --shard "$k/$n" --out "$out/shard-$k" --quiet "${resume[@]}" "$@" \
        >"$out/shard-$k.log" 2>&1 || rc=$?
    local ms=$((($(date +%s%N) - t0) / 1000000))
    printf 'shard %d/%d: exit %d, wall %d.%03d s (log %s)\n' "$k" "$n" "$rc" \
        $((ms / 1000)) $((ms % 1000)) "$out/shard-$k.log"
    return "$rc"
}

failed=0
for k in $(seq 1 "$n"); do
    while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || failed=1; done
    run_shard "$k" "$@" &
done
while [ "$(jobs -rp | wc -l)" -gt 0 ]; do wait -n || failed=1; done

dirs=()
for k in $(seq 1 "$n"); do dirs+=("$out/shard-$k"); done
rm -rf "$out/merged"
"$bin" merge "${dirs[@]}" --out "$out/merged" || failed=1
exit "$failed"
