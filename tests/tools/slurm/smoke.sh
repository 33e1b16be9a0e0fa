#!/usr/bin/env bash
# Smoke test of the one-node test cluster (cluster.sh): a 4-task job array and
# a merge job that depends on it (afterok). Checks each task's output, the
# merge output, and that the merge started only after every task had finished.
# Exit 0: passed; 77: skipped (no slurm/munge); other: failed.
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
cluster=$here/cluster.sh
prog=smoke.sh

rc=0
reason=$("$cluster" available) || rc=$?
if [[ $rc -eq 77 ]]; then
    echo "$prog: SKIP: $reason"
    exit 77
elif [[ $rc -ne 0 ]]; then
    echo "$prog: FAIL: cluster.sh available exited with $rc: $reason" >&2
    exit 1
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/slurm-smoke.XXXXXX")
cdir=$work/cluster
chmod 711 "$work"  # munged wants every folder above its socket traversable by all
out=$work/out
mkdir -p "$out"

cleanup() {
    local rc=$?
    "$cluster" stop "$cdir" || true
    if [[ $rc -ne 0 ]]; then
        echo "$prog: kept $work for inspection" >&2
    else
        rm -rf "$work"
    fi
    exit "$rc"
}
trap cleanup EXIT

fail() {
    echo "$prog: FAIL: $*" >&2
    local f
    for f in "$cdir"/log/slurmctld.log "$cdir"/log/slurmd.log "$out"/*.out; do
        [[ -s $f ]] || continue
        echo "--- $f (last lines)" >&2
        grep -v pmix "$f" | tail -n 10 | sed 's/^/    /' >&2 || true
    done
    if [[ -n ${SLURM_CONF:-} ]]; then
        echo "--- scontrol show job" >&2
        scontrol -o show job 2>&1 | sed 's/^/    /' >&2 || true
    fi
    exit 1
}

t0=$(date +%s.%N)
env_lines=$("$cluster" start "$cdir") || fail "cluster.sh start $cdir failed"
eval "$env_lines"
[[ -n ${SLURM_CONF:-} ]] || fail "cluster.sh start printed no SLURM_CONF"
t1=$(date +%s.%N)
echo "$prog: cluster started in $(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }') s"

# Each task: start time, its output, (1 s of work), end time. All writes go to
# *.tmp first and are renamed, so a reader never sees a partial file.
# shellcheck disable=SC2016  # the job scripts expand their variables themselves
array_id=$(sbatch --parsable --array=0-3 --chdir="$out" --output="$out/task-%A_%a.out" \
    --job-name=smoke-shard --wrap '
        i=$SLURM_ARRAY_TASK_ID
        date +%s.%N > start-$i.tmp && mv start-$i.tmp start-$i
        echo "$i" > task-$i.tmp && mv task-$i.tmp task-$i
        sleep 2
        date +%s.%N > end-$i.tmp && mv end-$i.tmp end-$i') ||
    fail "sbatch of the array job failed"
array_id=${array_id%%;*}

# shellcheck disable=SC2016
merge_id=$(sbatch --parsable --dependency="afterok:$array_id" --chdir="$out" \
    --output="$out/merge-%j.out" --job-name=smoke-merge --wrap '
        date +%s.%N > merge-start
        for i in 0 1 2 3; do printf "task-%s %s\n" "$i" "$(cat task-$i)"; done > merge.tmp
        mv merge.tmp merge') ||
    fail "sbatch of the merge job failed"
merge_id=${merge_id%%;*}
echo "$prog: submitted array job $array_id and merge job $merge_id (afterok:$array_id)"

# Wait (bounded) for the merge output and for both jobs to leave the queue.
deadline=$((SECONDS + 120))
while :; do
    queued=$(squeue -h -j "$array_id,$merge_id" -o '%i %T %r' 2>/dev/null) || queued="?"
    if [[ -s $out/merge && -z $queued ]]; then break; fi
    if [[ $queued == *DependencyNeverSatisfied* ]]; then
        fail "merge job $merge_id will never run (an array task failed)"
    fi
    (( SECONDS < deadline )) || fail "jobs not done within 120 s; still queued: ${queued:-none}"
    sleep 0.5
done
t2=$(date +%s.%N)

# Final states (no accounting: scontrol keeps finished jobs for MinJobAge=300 s).
bad=$(scontrol -o show job "$array_id" | grep -v 'JobState=COMPLETED .*ExitCode=0:0' || true)
[[ -z $bad ]] || fail "an array task did not complete with exit code 0: $bad"
scontrol -o show job "$merge_id" | grep -q 'JobState=COMPLETED .*ExitCode=0:0' ||
    fail "merge job $merge_id did not complete with exit code 0: $(scontrol -o show job "$merge_id")"
ntasks=$(scontrol -o show job "$array_id" | grep -c 'ArrayTaskId=' || true)
[[ $ntasks -eq 4 ]] || fail "expected 4 array tasks in scontrol, got $ntasks"

# Outputs.
for i in 0 1 2 3; do
    [[ -f $out/task-$i ]] || fail "task $i wrote no output ($out/task-$i)"
    [[ $(<"$out/task-$i") == "$i" ]] || fail "task-$i holds '$(<"$out/task-$i")', expected '$i'"
    [[ -f $out/end-$i ]] || fail "task $i wrote no end time"
done
expected=$'task-0 0\ntask-1 1\ntask-2 2\ntask-3 3'
[[ $(<"$out/merge") == "$expected" ]] ||
    fail "merge file differs: got '$(<"$out/merge")', expected '$expected'"

# Order: the merge started after the last task ended.
last_end=$(sort -g "$out"/end-? | tail -1)
merge_start=$(<"$out/merge-start")
awk -v m="$merge_start" -v e="$last_end" 'BEGIN { exit !(m >= e) }' ||
    fail "merge started at $merge_start, before the last array task ended at $last_end"

# Concurrency: with 2+ CPUs (CR_Core: one core per task) at least two tasks
# must have overlapped in time.
cpus=$(sinfo -h -n localhost -o '%c' | head -1)
overlap=0
for i in 0 1 2 3; do
    for j in 0 1 2 3; do
        [[ $i -lt $j ]] || continue
        if awk -v si="$(<"$out/start-$i")" -v ei="$(<"$out/end-$i")" \
               -v sj="$(<"$out/start-$j")" -v ej="$(<"$out/end-$j")" \
               'BEGIN { exit !(si < ej && sj < ei) }'; then
            overlap=$((overlap + 1))
        fi
    done
done
if [[ ${cpus:-1} -ge 2 && $overlap -eq 0 ]]; then
    fail "node has $cpus CPUs but no two array tasks ran at the same time"
fi

echo "$prog: array tasks: $(for i in 0 1 2 3; do printf '%s[%s..%s] ' "$i" \
    "$(awk -v t="$(<"$out/start-$i")" -v z="$t1" 'BEGIN { printf "%.1f", t - z }')" \
    "$(awk -v t="$(<"$out/end-$i")" -v z="$t1" 'BEGIN { printf "%.1f", t - z }')"; done)(s after start)"
echo "$prog: merge started $(awk -v m="$merge_start" -v e="$last_end" 'BEGIN { printf "%.2f", m - e }') s after the last task ended; overlapping task pairs: $overlap (node CPUs: $cpus)"
echo "$prog: jobs done $(awk -v a="$t1" -v b="$t2" 'BEGIN { printf "%.1f", b - a }') s after submission"
echo "$prog: PASS"
