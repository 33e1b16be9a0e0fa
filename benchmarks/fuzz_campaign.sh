#!/usr/bin/env bash
# A long fuzzing run of one libFuzzer target (tests/fuzz), continuing from a
# working corpus kept between runs, with its CPU time, executions, coverage
# and findings written down. Runs build on each other: the working corpus
# under out/fuzz-campaign/<target>/corpus starts from the committed corpus and
# keeps growing; tests/fuzz/CAMPAIGN.tsv is the ledger of every run (commit it),
# so the CPU time a target has had is the sum of its rows.
#
#   benchmarks/fuzz_campaign.sh TARGET SECONDS     # e.g. fuzz_glb 3600
#
# One fuzzing process (one core). Run it under `nice -n 19` beside other work;
# the ledger records CPU seconds, which is less than SECONDS when the core was
# busy with something else; libFuzzer's -timeout is wall-clock, so it is 60 s
# here (a unit starved at nice 19 on a busy machine took 11 s for a 0.5 s run:
# reproduce any timeout artifact unloaded before calling it a finding). Needs
# the sanitized build tree (scripts/fuzz-smoke
# makes it). Crashes land in out/fuzz-campaign/<target>/artifacts/; see
# tests/fuzz/README.md for what to do with them and for folding the working
# corpus back into the committed one (-merge=1).
set -euo pipefail
target="${1:?usage: $0 TARGET SECONDS}"
seconds="${2:?usage: $0 TARGET SECONDS}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${CITYATLAS_FUZZ_BUILD:-$root/build-fuzz}"
bin="$build/tests/fuzz/$target"
[ -x "$bin" ] || { echo "fuzz_campaign: $bin is not built (run scripts/fuzz-smoke 1 first)" >&2; exit 1; }

extra_seed=""
case "$target" in
  fuzz_citygml) seed="$root/tests/data/citygml_broken"; extra_seed="$root/tests/fuzz/corpus/$target"; max_len=65536 ;;
  fuzz_camera_path) seed="$root/tests/fuzz/corpus/$target"; max_len=8192 ;;
  fuzz_footprint_mapping) seed="$root/tests/fuzz/corpus/$target"; max_len=16384 ;;
  fuzz_tileset_json | fuzz_glb | fuzz_dds | fuzz_texture_blocks | fuzz_feature_table)
    seed="$root/tests/fuzz/corpus/$target"; max_len=65536 ;;
  *) echo "fuzz_campaign: unknown target $target" >&2; exit 2 ;;
esac

# Seed folders libFuzzer reads besides the working corpus (new finds go to the first folder only).
seeds=("$seed")
[ -n "${extra_seed:-}" ] && [ -d "$extra_seed" ] && seeds+=("$extra_seed")

work="$root/out/fuzz-campaign/$target"
mkdir -p "$work/corpus" "$work/artifacts" "$root/out/benchmarks"
[ -n "$(ls -A "$work/corpus")" ] || cp -r "$seed/." "$work/corpus/"
before=$(ls -A "$work/artifacts" | wc -l)
log="$work/run-$(date -u +%Y%m%dT%H%M%SZ).log"

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}"
TIMEFORMAT='%U %S'
rc=0
{ time (cd "$work" && "$bin" "$work/corpus" "${seeds[@]}" -max_total_time="$seconds" -timeout=60 -rss_limit_mb=2048 \
     -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$work/artifacts/" > "$log" 2>&1) || rc=$?; } 2> "$work/cpu.txt"
read -r user sys < "$work/cpu.txt"
cpu=$(python3 -c "print(round($user + $sys))")
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | cut -d' ' -f2)
files=$(ls -A "$work/corpus" | wc -l)
found=$(( $(ls -A "$work/artifacts" | wc -l) - before ))
commit=$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)
row="$(date -u +%Y-%m-%d)	$commit	$target	$cpu	${execs:-0}	${cov:-0}	${ft:-0}	$files	$found	$rc"
ledger="$root/tests/fuzz/CAMPAIGN.tsv"
[ -f "$ledger" ] || printf 'date\tcommit\ttarget\tcpu_s\texecs\tcov\tft\tcorpus_files\tfindings\texit\n' > "$ledger"
printf '%s\n' "$row" >> "$ledger"
printf '%s\n' "$row" >> "$root/out/benchmarks/fuzz_campaign.tsv"
echo "fuzz_campaign: $target: ${cpu} CPU s, ${execs:-0} runs, cov ${cov:-0} ft ${ft:-0}, corpus ${files} files, findings ${found}, exit ${rc}; log $log"
[ "$found" -eq 0 ] && [ "$rc" -eq 0 ]
