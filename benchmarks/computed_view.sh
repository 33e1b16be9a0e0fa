#!/usr/bin/env bash
# Benchmark: what showing a computed texture (issue 19; render --computed)
# costs per frame on this machine's OpenGL (Mesa llvmpipe without a GPU), and
# the README's pictures of it. The demo town (out/demo-town, ./scripts/demo)
# is built with --unique-charts and the sky view and sun hours at their
# defaults; one oblique camera over it with its ideal set loaded (--wait):
# the photo against each computed mode and against the photo with edge
# enhancement (--edges), median frame time over FRAMES frames, and the bytes
# each loads.
# Usage: benchmarks/computed_view.sh [SIZE=1280x720] [FRAMES=30] [PICTURES=out/benchmarks/computed]
# Writes out/benchmarks/computed_view.json and PICTURES/computed-<name>.png
# (the README's are docs/computed-*.png, made with PICTURES=docs SIZE=640x360).
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE="${1:-1280x720}"; FRAMES="${2:-30}"; PICTURES="${3:-out/benchmarks/computed}"
CITYATLAS="${CITYATLAS:-./build/cli/cityatlas}"
[ -n "${CITYATLAS_NO_BUILD:-}" ] || ./scripts/build > /dev/null
TOWN=out/demo-town; TILES=out/benchmarks/computed-tiles
[ -f "$TOWN/town.gml" ] || "$CITYATLAS" synth --buildings 200 --lod 2 --seed 1 -o "$TOWN" --overwrite -q > /dev/null
"$CITYATLAS" build "$TOWN/town.gml" -o "$TILES" --unique-charts --computed sky_view --computed sun_hours -q > /dev/null
WORK=out/benchmarks/computed-work; rm -rf "$WORK"; mkdir -p "$WORK" "$PICTURES"
/usr/bin/python3 - "$TILES" "$SIZE" "$FRAMES" "$PICTURES" "$WORK" "$CITYATLAS" <<'PY'
import json, shutil, statistics, subprocess, sys
tiles, size, frames, pictures, work, cityatlas = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5], sys.argv[6]
t = json.load(open(f"{tiles}/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
look = [c[0], c[1], c[2] - hz]
cam = [c[0] - 0.35 * hx, c[1] - 1.1 * hy, c[2] - hz + 0.9 * max(hx, hy)]
keys = [{"time_s": 0, "position": cam, "look_at": look}, {"time_s": frames - 1, "position": cam, "look_at": look}]
path = f"{work}/path.json"
json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": keys}, open(path, "w"))
views = {"photo": [], "sky-view": ["--computed", "sky_view"], "sun-hours": ["--computed", "sun_hours"],
         "sky-view-modulate": ["--computed", "sky_view", "--computed-mode", "modulate"],
         "photo-edges": ["--edges"]}  # edge enhancement (render/gl/edge_pass.h): its pass inside the frame time
runs = []
for name, extra in views.items():
    out = f"{work}/{name}"
    subprocess.run([cityatlas, "render", tiles, "--path", path, "--size", size, "--wait", "--anisotropy", "1",
                    "--every", str(frames), "-o", out, "-q"] + extra, check=True)
    r = json.load(open(f"{out}/report.json"))
    ms = [f["frame_ms"] for f in r["frames"][1:]]
    runs.append({"view": name, "frame_ms_median": round(statistics.median(ms), 2), "frame_ms_max": round(max(ms), 2),
                 "bytes_loaded": sum(f["bytes_loaded"] for f in r["frames"]),
                 "computed_blocks": sum(f["requests"]["computed"] for f in r["frames"]),
                 "texture_binds": r["frames"][-1]["texture_binds"], "renderer": r["gl"]["renderer"]})
    shutil.copy(f"{out}/frame_00000.png", f"{pictures}/computed-{name}.png")
base = runs[0]
for r in runs:
    r["overhead_ms"] = round(r["frame_ms_median"] - base["frame_ms_median"], 2)
    r["extra_bytes"] = r["bytes_loaded"] - base["bytes_loaded"]
computed = t["extras"]["cityatlas"]["computed"]
json.dump({"benchmark": "computed_view", "tiles": tiles, "size": size, "camera": cam, "runs": runs,
           "computed": [{"name": x["name"], "bytes": x["bytes"]} for x in computed],
           "atlas_bytes": t["extras"]["cityatlas"]["totals"]["bytes"]["atlases"]},
          open("out/benchmarks/computed_view.json", "w"), indent=1)
print(f"{'view':18s} {'median ms':>10s} {'overhead':>9s} {'extra bytes':>12s} {'binds':>6s}   ({runs[0]['renderer']}, {size})")
for r in runs:
    print(f"{r['view']:18s} {r['frame_ms_median']:10.2f} {r['overhead_ms']:9.2f} {r['extra_bytes']:12d} {r['texture_binds']:6d}")
print(f"pictures: {pictures}/computed-*.png")
PY
