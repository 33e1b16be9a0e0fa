#!/usr/bin/env bash
# The client under HTTP faults: `cityatlas render` streams a town from
# `cityatlas serve` through tests/tools/fault_proxy.py, which for
# FAULT_SECONDS spoils a share P of the responses (500/503, resets, cut bodies,
# stalls, dripped answers, lying Content-Length), then passes everything.
# The camera holds one street-level view for the whole run. Checked: render
# exits 0 (no crash), no frame over the budget, errors reported, and the ideal
# set complete again after the faults stop; measured: the time it takes.
# Usage: benchmarks/http_faults.sh [FAULT_SECONDS=20] [P=0.5] [CALM_SECONDS=40]
# Env: CITYATLAS (binary), RESULT (default out/benchmarks/http_faults.json).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
FAULT_S="${1:-20}"; P="${2:-0.5}"; CALM_S="${3:-40}"
BIN="${CITYATLAS:-$ROOT/build/cli/cityatlas}"
RESULT="${RESULT:-$ROOT/out/benchmarks/http_faults.json}"
mkdir -p "$(dirname "$RESULT")"
WORK=$(mktemp -d /tmp/cityatlas_faults.XXXXXX)
PIDS=()
cleanup() { for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; done; rm -rf "$WORK"; }
trap cleanup EXIT
[ -n "${KEEP:-}" ] && trap 'for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; done; echo "kept $WORK"' EXIT
cd "$WORK"
"$BIN" synth -q --buildings 60 --seed 4 --texture-size 64 -o town > /dev/null
"$BIN" build -q town/town.gml -o out --d-min 30 > /dev/null
"$BIN" serve -q out --port 0 > serve.txt 2>&1 & PIDS+=($!)
# Up to 30 s for each to start: on two busy cores (the full test suite) 5 s was not always enough.
for _ in $(seq 600); do grep -q serving serve.txt 2>/dev/null && break; sleep 0.05; done
SPORT=$(sed -n 's|.*127.0.0.1:\([0-9]*\)/.*|\1|p' serve.txt)
[ -n "$SPORT" ] || { echo "http_faults: the server did not start in 30 s: $(cat serve.txt)" >&2; exit 1; }
python3 "$ROOT/tests/tools/fault_proxy.py" "$SPORT" --port-file proxy.port --log proxy.json --p "$P" \
  --fault-seconds "$FAULT_S" > proxy.txt 2>&1 & PIDS+=($!)
for _ in $(seq 600); do [ -s proxy.port ] && break; sleep 0.05; done
[ -s proxy.port ] || { echo "http_faults: the fault proxy did not start in 30 s: $(cat proxy.txt)" >&2; exit 1; }
PPORT=$(cat proxy.port)
python3 - "$FAULT_S" "$CALM_S" <<'PY'
import json, sys
fault_s, calm_s = float(sys.argv[1]), float(sys.argv[2])
t = json.load(open("out/tileset.json"))
b = t["root"]["boundingVolume"]["box"]
c, hx, hy, hz = b[0:3], b[3], b[7], b[11]
pos = [c[0], c[1] - 0.5 * hy, c[2] + hz + 8]
d = [0.0, 0.5 * hy, -(hz + 8)]
n = sum(v * v for v in d) ** 0.5
d = [v / n for v in d]
dur = fault_s + calm_s
json.dump({"frame_rate": 10, "keyframes": [{"time_s": 0, "position": pos, "direction": d, "label": "street"},
                                          {"time_s": dur, "position": pos, "direction": d, "label": "street"}]},
          open("path.json", "w"))
PY
start=$(date +%s.%N)
set +e
"$BIN" render "http://127.0.0.1:$PPORT/" --path path.json --size 320x180 --budget 64M -o frames --every 100000 \
  --report report.json -q > render.txt 2>&1
rc=$?
set -e
python3 - "$start" "$rc" "$RESULT" "$FAULT_S" "$P" <<'PY'
import json, sys, collections
start, rc, result, fault_s, p = float(sys.argv[1]), int(sys.argv[2]), sys.argv[3], float(sys.argv[4]), float(sys.argv[5])
px = json.load(open("proxy.json"))
faults = collections.Counter(r["fault"] for r in px["requests"] if r["fault"])
out = {"fault_seconds": fault_s, "p": p, "render_exit": rc, "requests": len(px["requests"]), "faults": dict(faults)}
ok = rc == 0
if rc != 0:
    out["render_output"] = open("render.txt").read().strip().splitlines()[-5:]
try:
    r = json.load(open("report.json"))
except Exception as e:
    r = None; out["report"] = f"missing: {e}"; ok = False
if r:
    s = r["summary"]; frames = r["frames"]
    stop = px["faults_stopped_at"]
    stop_wall = (stop - start) if stop else None
    conv = None
    for i, f in enumerate(frames):
        if stop_wall is not None and f["wall_s"] >= stop_wall and all(
                g["ideal_set_complete"] and g["failed_blocks"] == 0 for g in frames[i:]):
            conv = round(f["wall_s"] - stop_wall, 2); break
    out.update({"frames": s["frames"], "frames_over_budget": s["frames_over_budget"], "errors": s["errors"],
                "retries": s["retries"], "frames_root_missing": s["frames_root_missing"],
                "resident_bytes_max": s["resident_bytes_max"], "budget_bytes": r["settings"]["budget_bytes"],
                "faults_stopped_at_wall_s": round(stop_wall, 2) if stop_wall else None,
                "seconds_to_complete_ideal_set_after_faults": conv,
                "error_examples": s["error_messages"][:5]})
    ok = ok and s["frames_over_budget"] == 0 and s["errors"] > 0 and conv is not None
out["ok"] = ok
print(json.dumps(out, indent=1))
json.dump(out, open(result, "w"), indent=1)
sys.exit(0 if ok else 1)
PY
