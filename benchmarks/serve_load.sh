#!/usr/bin/env bash
# `cityatlas serve` under load for longer: CLIENTS (64) concurrent clients for
# SECONDS (60) on a 200-building town's folder; writes
# out/benchmarks/serve_load.json (requests, failures, fds and RSS before,
# under load and after). Usage: benchmarks/serve_load.sh [SECONDS] [CLIENTS]
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_RUN="${1:-60}"
CLIENTS="${2:-64}"
BIN=./build/cli/cityatlas
[ -x "$BIN" ] || ./scripts/build > /dev/null
WORK=$(mktemp -d /tmp/cityatlas_serve_load.XXXXXX)
mkdir -p out/benchmarks
"$BIN" synth -q --buildings 200 --seed 5 --texture-size 128 -o "$WORK/town" > /dev/null
"$BIN" build -q "$WORK/town/town.gml" -o "$WORK/out" > /dev/null
ln -s /etc/passwd "$WORK/out/leak"
"$BIN" serve -q "$WORK/out" --port 0 > "$WORK/serve.txt" 2>&1 &
SERVER=$!
trap 'kill $SERVER 2>/dev/null || true; rm -rf "$WORK"' EXIT
for _ in $(seq 100); do grep -q serving "$WORK/serve.txt" 2>/dev/null && break; sleep 0.05; done
PORT=$(sed -n 's|.*127.0.0.1:\([0-9]*\)/.*|\1|p' "$WORK/serve.txt")
python3 tests/tools/serve_load.py "http://127.0.0.1:$PORT/" "$WORK/out" "$SERVER" --clients "$CLIENTS" \
  --seconds "$SECONDS_RUN" --json out/benchmarks/serve_load.json
