#!/usr/bin/env bash
# Benchmark: the client's RAM level (issue 18; papers/004's texture cache).
# Real time over nginx on loopback, rate-limited per connection (12 MB/s by
# default), a street-level view A, a teleport to street-level view B at the
# other end of the town, a teleport back to A, with a GPU budget that holds
# one view's ideal set but not both: bytes fetched and seconds to the complete
# ideal set after each teleport, RAM level off and on (default: twice the
# budget); each in real time and loading alone (--wait). Not a test: the
# figures depend on the machine.
# Usage: benchmarks/ram_level.sh [TILES=out/benchmarks/build-10000-400-default] [RATE=12m] [SIZE=1280x720]
# Writes out/benchmarks/ram_level-<tiles name>.json and prints a table.
set -euo pipefail
cd "$(dirname "$0")/.."
TILES="${1:-out/benchmarks/build-10000-400-default}"; RATE="${2:-12m}"; SIZE="${3:-1280x720}"
CITYATLAS="${CITYATLAS:-./build/cli/cityatlas}"
[ -n "${CITYATLAS_NO_BUILD:-}" ] || ./scripts/build > /dev/null
if [ ! -f "$TILES/tileset.json" ]; then
  echo "no tile folder at $TILES: run benchmarks/build_scale.sh 10000 400 main first (or give a folder)" >&2
  exit 1
fi
NAME=$(basename "$TILES")
WORK="out/benchmarks/ram_level-$NAME"; rm -rf "$WORK"; mkdir -p "$WORK"
NGINX_SERVE=tests/render/nginx/nginx_serve.sh
PORT=$(bash "$NGINX_SERVE" start "$PWD/$TILES" "$PWD/$WORK/nginx" "$RATE")
trap 'bash "$NGINX_SERVE" stop "$PWD/$WORK/nginx" || true' EXIT
/usr/bin/python3 - "$TILES" "$WORK" "http://127.0.0.1:$PORT/" "$SIZE" "$RATE" "$CITYATLAS" <<'PY'
import json, subprocess, sys
tiles, work, url, size, rate, cityatlas = sys.argv[1:7]
t = json.load(open(f"{tiles}/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
z0 = c[2] - hz
A = {"position": [c[0] - 0.2 * hx, c[1] - 0.5 * hy, z0 + 1.7], "look_at": [c[0] - 0.2 * hx, c[1], z0 + 5]}
B = {"position": [c[0] + 0.2 * hx, c[1] + 0.5 * hy, z0 + 1.7], "look_at": [c[0] + 0.2 * hx, c[1], z0 + 5]}
def path(name, keys, fps=10):
    json.dump({"interpolation": "linear", "frame_rate": fps, "keyframes": keys}, open(f"{work}/{name}.json", "w"), indent=1)
    return f"{work}/{name}.json"
# Each view's ideal set with everything allowed (--wait, a large budget).
probe = path("probe", [dict(A, time_s=0), dict(B, time_s=1, cut=True)], fps=1)
subprocess.run([cityatlas, "render", tiles, "--path", probe, "--size", size, "--wait", "--budget", "64G", "--anisotropy", "1",
                "--report", f"{work}/probe-report.json", "-q"], check=True)
frames = json.load(open(f"{work}/probe-report.json"))["frames"]
ideal_a, ideal_b, pinned = frames[0]["ideal_bytes"], frames[1]["ideal_bytes"], frames[0]["pinned_bytes"]
budget = pinned + max(ideal_a, ideal_b)
flight = path("flight", [dict(A, time_s=0, label="A"), dict(A, time_s=6), dict(B, time_s=6.1, cut=True, label="to B"),
                         dict(B, time_s=12), dict(A, time_s=12.1, cut=True, label="back to A"), dict(A, time_s=18)])
runs = []
for name, ram in (("RAM level off", "0"), ("RAM level on (2x budget)", str(2 * budget))):
    report = f"{work}/{name.split()[2]}.json"
    subprocess.run([cityatlas, "render", url, "--path", flight, "--size", size, "--budget", str(budget), "--ram-budget", ram,
                    "--anisotropy", "1", "--report", report, "-q"], check=True)
    r = json.load(open(report))
    fr = r["frames"]
    tele = r["summary"]["teleports"]
    back = [x for x in tele if x["label"] == "back to A"][0]
    start = back["frame"]
    runs.append({"run": name, "ram_budget_bytes": int(ram), "gpu_budget_bytes": budget,
                 "bytes_fetched_total": sum(f["bytes_loaded"] for f in fr),
                 "bytes_fetched_back_to_A": sum(f["bytes_loaded"] for f in fr[start:]),
                 "ram_hits_back_to_A": sum(f["ram_hits"] for f in fr[start:]),
                 "seconds_to_ideal_set": {x["label"]: x["seconds_to_ideal_set"] for x in tele},
                 "ram_bytes_max": max(f["ram_bytes"] for f in fr)})
    # The same flight loading each frame's ideal set before drawing it: the
    # teleport frames' wait is the loading pipeline alone (fetch, decode,
    # upload), without llvmpipe's drawing taking the CPU between frames (on
    # this machine it takes 80 % of it at 1280x720; a GPU draws in a few ms).
    waited = f"{work}/{name.split()[2]}-wait.json"
    subprocess.run([cityatlas, "render", url, "--path", flight, "--size", size, "--budget", str(budget), "--ram-budget", ram,
                    "--anisotropy", "1", "--wait", "--report", waited, "-q"], check=True)
    fw = json.load(open(waited))["frames"]
    runs[-1]["seconds_loading_alone"] = {label: max(f["waited_ms"] for f in fw if f["label"] == label) / 1000
                                         for label in ("to B", "back to A")}
json.dump({"benchmark": "ram_level", "tiles": tiles, "rate_per_connection": rate, "size": size,
           "ideal_bytes": {"A": ideal_a, "B": ideal_b}, "runs": runs}, open(f"out/benchmarks/ram_level-{tiles.rstrip('/').split('/')[-1]}.json", "w"), indent=1)
print(f"nginx at {rate}/s per connection, GPU budget {budget / 1e6:.1f} MB (ideal sets: A {ideal_a / 1e6:.1f} MB, B {ideal_b / 1e6:.1f} MB)")
print("seconds to the complete ideal set after each teleport: real time (drawing on llvmpipe meanwhile) | loading alone (--wait)")
print(f"{'run':26s} {'fetched':>10s} {'back to A':>10s} {'RAM hits':>9s} {'to B s':>7s} {'back s':>7s} | {'to B s':>7s} {'back s':>7s}")
for r in runs:
    s, w = r["seconds_to_ideal_set"], r["seconds_loading_alone"]
    fmt = lambda v: "never" if v is None else f"{v:.2f}"
    print(f"{r['run']:26s} {r['bytes_fetched_total'] / 1e6:9.1f}M {r['bytes_fetched_back_to_A'] / 1e6:9.1f}M {r['ram_hits_back_to_A']:9d} "
          f"{fmt(s.get('to B')):>7s} {fmt(s.get('back to A')):>7s} | {fmt(w.get('to B')):>7s} {fmt(w.get('back to A')):>7s}")
PY
