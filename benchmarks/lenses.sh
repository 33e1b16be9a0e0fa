#!/usr/bin/env bash
# Benchmark: what each information lens (render/core/lenses.h, papers/003)
# costs per frame, on this machine's OpenGL (Mesa llvmpipe without a GPU):
# the same street-level camera with its ideal set loaded (--wait), no lens
# against each lens, median frame time over FRAMES frames; plus one picture
# per lens. A building near the town's centre is the building of interest
# (highlighted orange with the occlusion lenses).
# Usage: benchmarks/lenses.sh [TILES=out/demo-tiles] [SIZE=1280x720] [FRAMES=30] [PICTURES=out/benchmarks/lenses]
# Writes out/benchmarks/lenses.json, the pictures (lens-<name>.png) into
# PICTURES (the README's are docs/lens-*.png, made with PICTURES=docs).
set -euo pipefail
cd "$(dirname "$0")/.."
TILES="${1:-out/demo-tiles}"; SIZE="${2:-1280x720}"; FRAMES="${3:-30}"; PICTURES="${4:-out/benchmarks/lenses}"
CITYATLAS="${CITYATLAS:-./build/cli/cityatlas}"
[ -n "${CITYATLAS_NO_BUILD:-}" ] || ./scripts/build > /dev/null
[ -f "$TILES/tileset.json" ] || { echo "no tile folder at $TILES: run ./scripts/demo first (or give one)" >&2; exit 1; }
WORK=out/benchmarks/lenses-work; rm -rf "$WORK"; mkdir -p "$WORK" "$PICTURES"
/usr/bin/python3 - "$TILES" "$SIZE" "$FRAMES" "$PICTURES" "$WORK" "$CITYATLAS" <<'PY'
import json, os, shutil, statistics, struct, subprocess, sys
tiles, size, frames, pictures, work, cityatlas = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5], sys.argv[6]
t = json.load(open(f"{tiles}/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
z0 = c[2] - hz
boxes = []
for table in t["extras"]["cityatlas"]["features"]["tables"]:
    raw = open(f"{tiles}/{table['bounds']['uri']}", "rb").read()
    boxes += [struct.unpack_from("<6f", raw, 32 * i) for i in range(len(raw) // 32)]
poi = min(range(len(boxes)), key=lambda i: ((boxes[i][0] + boxes[i][3]) / 2 - c[0]) ** 2 + ((boxes[i][1] + boxes[i][4]) / 2 - c[1]) ** 2)
pc = [(boxes[poi][k] + boxes[poi][k + 3]) / 2 for k in range(3)]
cam = [pc[0] - 40, pc[1] - 120, z0 + 25]
lenses = {"none": None,
          "discard": {"building": poi, "occlusion": "discard", "highlight": [poi]},
          "xray": {"building": poi, "occlusion": "xray", "xray_falloff": 0.5, "highlight": [poi]},
          "flatten": {"building": poi, "occlusion": "flatten", "highlight": [poi]},
          "height": {"colour_by": "height", "highlight": [poi]},
          "sphere": {"shape": "sphere", "centre": pc, "radius_m": 60}}
runs = []
for name, lens in lenses.items():
    keys = [{"time_s": 0, "position": cam, "look_at": pc}, {"time_s": frames - 1, "position": cam, "look_at": pc}]
    path = f"{work}/{name}.json"
    json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": keys, **({"lens": lens} if lens else {})}, open(path, "w"))
    out = f"{work}/{name}"
    subprocess.run([cityatlas, "render", tiles, "--path", path, "--size", size, "--wait", "--anisotropy", "1",
                    "--every", str(frames), "-o", out, "-q"], check=True)
    r = json.load(open(f"{out}/report.json"))
    ms = [f["frame_ms"] for f in r["frames"][1:]]
    runs.append({"lens": name, "frame_ms_median": round(statistics.median(ms), 2), "frame_ms_max": round(max(ms), 2),
                 "styled_buildings": r["frames"][-1]["lens_occluders"], "renderer": r["gl"]["renderer"]})
    shutil.copy(f"{out}/frame_00000.png", f"{pictures}/lens-{name}.png")
base = runs[0]["frame_ms_median"]
for r in runs: r["overhead_ms"] = round(r["frame_ms_median"] - base, 2)
json.dump({"benchmark": "lenses", "tiles": tiles, "size": size, "building": poi, "runs": runs},
          open("out/benchmarks/lenses.json", "w"), indent=1)
print(f"{'lens':10s} {'median ms':>10s} {'overhead':>9s} {'styled':>7s}   ({runs[0]['renderer']}, {size})")
for r in runs: print(f"{r['lens']:10s} {r['frame_ms_median']:10.2f} {r['overhead_ms']:9.2f} {r['styled_buildings']:7d}")
print(f"pictures: {pictures}/lens-*.png")
PY
