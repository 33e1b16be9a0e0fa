#!/usr/bin/env bash
# SIGKILL trials: `cityatlas build` killed at uniformly random moments over a
# whole build (read, atlas, tiles, the final swap) must leave the previous
# complete folder or none, never a partial one, and the next run must clean up
# and succeed. Usage: benchmarks/kill_build.sh [TRIALS=24] [BUILDINGS=1500]
# Writes out/benchmarks/kill_build.tsv (one row per trial) and prints a summary.
set -euo pipefail
cd "$(dirname "$0")/.."
TRIALS="${1:-24}"
BUILDINGS="${2:-1500}"
BIN=./build/cli/cityatlas
[ -x "$BIN" ] || ./scripts/build > /dev/null
WORK=$(mktemp -d /tmp/cityatlas_kill.XXXXXX)
trap 'rm -rf "$WORK"' EXIT
mkdir -p out/benchmarks
OUT_TSV=out/benchmarks/kill_build.tsv

"$BIN" synth -q --buildings "$BUILDINGS" --seed 9 --texture-size 128 -o "$WORK/town" > /dev/null
t0=$(date +%s.%N)
"$BIN" build -q "$WORK/town/town.gml" -o "$WORK/out" > /dev/null
t1=$(date +%s.%N)
full_s=$(python3 -c "print(round($t1 - $t0, 2))")
hash=$(python3 -c "import json; print(json.load(open('$WORK/out/tileset.json'))['asset']['tilesetVersion'])")
echo "full build: $full_s s ($BUILDINGS buildings); $TRIALS trials, kill at U(0, $full_s) s of a --force rebuild"
printf 'trial\tkill_at_s\tstage_at_kill\tfound\tinspect\trerun\n' > "$OUT_TSV"
partial=0 none=0 bad=0
for trial in $(seq "$TRIALS"); do
  at=$(python3 -c "import random; print(round(random.uniform(0, $full_s), 2))")
  "$BIN" build --force "$WORK/town/town.gml" -o "$WORK/out" > /dev/null 2> "$WORK/progress.txt" &
  pid=$!
  sleep "$at"
  kill -9 "$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
  stage=$( (tr '\r' '\n' < "$WORK/progress.txt" | grep -v '^$' || true) | tail -1 | cut -c1-40 | tr '\t' ' ')
  [ -n "$stage" ] || stage="-"
  found=none inspect=-
  if [ -e "$WORK/out" ]; then
    found=folder
    if "$BIN" inspect -q "$WORK/out" > /dev/null 2>&1; then inspect=ok; else inspect=DEFECTS; bad=$((bad + 1)); fi
  elif [ -e "$WORK/out.old" ]; then
    found=old_only; none=$((none + 1))
  else
    found=NOTHING; bad=$((bad + 1))
  fi
  [ -e "$WORK/out.partial" ] && partial=$((partial + 1))
  if "$BIN" build -q "$WORK/town/town.gml" -o "$WORK/out" > /dev/null 2>&1 && "$BIN" inspect -q "$WORK/out" > /dev/null 2>&1 &&
     [ ! -e "$WORK/out.partial" ] && [ ! -e "$WORK/out.old" ]; then rerun=ok; else rerun=FAILED; bad=$((bad + 1)); fi
  printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$trial" "$at" "$stage" "$found" "$inspect" "$rerun" >> "$OUT_TSV"
done
column -t -s $'\t' "$OUT_TSV"
echo "summary: $TRIALS trials; partial working folders left by the kill: $partial (removed by the rerun); out missing (out.old kept): $none; defects or failed reruns: $bad"
[ "$bad" -eq 0 ]
