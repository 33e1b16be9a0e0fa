#!/usr/bin/env bash
# Benchmark: bandwidth spent for nothing in a fast flight (issue 18; papers/004
# §4.5's speed rule). Real time over nginx on loopback, rate-limited per
# connection (12 MB/s by default): a street-level run at 150 m/s along the
# town, then a hold; the client's budget a tenth of the folder. Policies: none,
# --speed-limit 40, --tau-speed 20, --lookahead-s 0.5. Per run: bytes fetched
# in all, bytes fetched and then evicted without ever being drawn (wasted),
# frames with needed blocks missing while fast and after stopping, and
# seconds to the complete ideal set after stopping.
# Usage: benchmarks/speed_policy.sh [TILES=out/benchmarks/build-10000-400-default] [RATE=12m] [SIZE=1280x720]
# Writes out/benchmarks/speed_policy-<tiles name>.json and prints a table.
set -euo pipefail
cd "$(dirname "$0")/.."
TILES="${1:-out/benchmarks/build-10000-400-default}"; RATE="${2:-12m}"; SIZE="${3:-1280x720}"
CITYATLAS="${CITYATLAS:-./build/cli/cityatlas}"
[ -n "${CITYATLAS_NO_BUILD:-}" ] || ./scripts/build > /dev/null
[ -f "$TILES/tileset.json" ] || { echo "no tile folder at $TILES: run benchmarks/build_scale.sh 10000 400 main first" >&2; exit 1; }
NAME=$(basename "$TILES")
WORK="out/benchmarks/speed_policy-$NAME"; rm -rf "$WORK"; mkdir -p "$WORK"
NGINX_SERVE=tests/render/nginx/nginx_serve.sh
PORT=$(bash "$NGINX_SERVE" start "$PWD/$TILES" "$PWD/$WORK/nginx" "$RATE")
trap 'bash "$NGINX_SERVE" stop "$PWD/$WORK/nginx" || true' EXIT
/usr/bin/python3 - "$TILES" "$WORK" "http://127.0.0.1:$PORT/" "$SIZE" "$RATE" "$CITYATLAS" <<'PY'
import json, subprocess, sys
tiles, work, url, size, rate, cityatlas = sys.argv[1:7]
t = json.load(open(f"{tiles}/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
z0 = c[2] - hz
totals = t["extras"]["cityatlas"]["totals"]["bytes"]
budget = (totals["geometry"] + totals["atlases"] + totals["textures"]) // 10
x0, x1, y = c[0] - 0.8 * hx, c[0] + 0.8 * hx, c[1] - 0.3 * hy
run_s = (x1 - x0) / 150.0
at = lambda x: {"position": [x, y, z0 + 1.7], "direction": [1, 0.15, -0.02]}
keys = [dict(at(x0), time_s=0, label="start"), dict(at(x0), time_s=2),
        dict(at(x1), time_s=2 + run_s, label="stop"), dict(at(x1), time_s=6 + run_s)]
json.dump({"interpolation": "linear", "frame_rate": 10, "keyframes": keys}, open(f"{work}/path.json", "w"), indent=1)
runs = []
for name, extra in (("no policy", []), ("--speed-limit 40", ["--speed-limit", "40"]),
                    ("--tau-speed 20", ["--tau-speed", "20"]), ("--lookahead-s 0.5", ["--lookahead-s", "0.5"])):
    report = f"{work}/{name.replace(' ', '_').strip('-')}.json"
    subprocess.run([cityatlas, "render", url, "--path", f"{work}/path.json", "--size", size, "--budget", str(budget),
                    "--anisotropy", "1", "--report", report, "-q"] + extra, check=True)
    fr = json.load(open(report))["frames"]
    fast = [f for f in fr if f["speed_mps"] > 40]
    stop = next(i for i, f in enumerate(fr) if f["time_s"] >= 2 + run_s)
    done = next((f["wall_s"] - fr[stop]["wall_s"] for f in fr[stop:] if f["refinement"]["ideal_missing"] == 0), None)
    runs.append({"run": name, "bytes_fetched": sum(f["bytes_loaded"] for f in fr), "bytes_wasted": fr[-1]["wasted_bytes"],
                 "fast_frames": len(fast), "fast_frames_needed_missing": sum(f["refinement"]["needed_missing"] > 0 for f in fast),
                 "seconds_to_ideal_set_after_stop": done})
json.dump({"benchmark": "speed_policy", "tiles": tiles, "rate_per_connection": rate, "budget_bytes": budget,
           "speed_mps": 150, "runs": runs}, open(f"out/benchmarks/speed_policy-{tiles.rstrip('/').split('/')[-1]}.json", "w"), indent=1)
print(f"nginx at {rate}/s per connection, budget {budget / 1e6:.0f} MB, 150 m/s for {run_s:.1f} s at street level")
print(f"{'run':20s} {'fetched':>9s} {'wasted':>9s} {'fast frames missing':>20s} {'ideal set after stop':>21s}")
for r in runs:
    d = r["seconds_to_ideal_set_after_stop"]
    print(f"{r['run']:20s} {r['bytes_fetched'] / 1e6:8.1f}M {r['bytes_wasted'] / 1e6:8.1f}M "
          f"{r['fast_frames_needed_missing']:>12d} of {r['fast_frames']:<5d} {('never' if d is None else f'{d:.2f} s'):>21s}")
PY
