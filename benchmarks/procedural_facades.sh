#!/usr/bin/env bash
# Benchmark: what --procedural-facades costs on footprint data (the demo
# town's footprints with their facade photos dropped, as open footprint data
# comes), and the README's picture of it: build time and bytes with and
# without, and one oblique view of each.
# Usage: benchmarks/procedural_facades.sh [BUILDINGS=200] [SIZE=1280x720] [PICTURES=out/benchmarks/procedural]
# Writes out/benchmarks/procedural_facades.json and PICTURES/procedural-{plain,plain-edges,facades}.png
# (the README's: docs/, made with SIZE=640x360 PICTURES=docs).
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-200}"; SIZE="${2:-1280x720}"; PICTURES="${3:-out/benchmarks/procedural}"
CITYATLAS="${CITYATLAS:-./build/cli/cityatlas}"
[ -n "${CITYATLAS_NO_BUILD:-}" ] || ./scripts/build > /dev/null
WORK=out/benchmarks/procedural-work; rm -rf "$WORK"; mkdir -p "$WORK/bare" "$PICTURES"
"$CITYATLAS" synth --buildings "$N" --lod 2 --seed 1 -o "$WORK/town" -q > /dev/null
ogr2ogr -q -select gml_id,height,eave_h,roof_h,base_h,levels,storey_h,roof_shape "$WORK/bare/bare.shp" "$WORK/town/footprints.shp"
/usr/bin/python3 - "$WORK" "$SIZE" "$PICTURES" "$CITYATLAS" <<'PY'
import json, shutil, subprocess, sys, time
work, size, pictures, cityatlas = sys.argv[1:5]
runs = []
for name, extra in [("plain", []), ("facades", ["--procedural-facades"])]:
    out = f"{work}/{name}"
    t0 = time.monotonic()
    subprocess.run([cityatlas, "build", f"{work}/bare/bare.shp", "-o", out, "-q", "--force"] + extra, check=True,
                   stdout=subprocess.DEVNULL)
    wall = time.monotonic() - t0
    rep = json.load(open(f"{out}/build_report.json"))
    t = json.load(open(f"{out}/tileset.json"))
    b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
    look = [c[0], c[1] - 0.2 * hy, c[2] - hz]
    cam = [c[0] - 0.2 * hx, c[1] - 0.75 * hy, c[2] - hz + 0.35 * max(hx, hy)]
    json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": [{"time_s": 0, "position": cam, "look_at": look}]},
              open(f"{work}/path.json", "w"))
    subprocess.run([cityatlas, "render", out, "--path", f"{work}/path.json", "--size", size, "--wait", "--frames", "1",
                    "-o", f"{out}-frames", "-q"], check=True)
    shutil.copy(f"{out}-frames/frame_00000.png", f"{pictures}/procedural-{name}.png")
    if name == "plain":  # the same boxes with edge enhancement (render --edges), the other way to read them apart
        subprocess.run([cityatlas, "render", out, "--path", f"{work}/path.json", "--size", size, "--wait", "--frames", "1",
                        "-o", f"{out}-edges", "-q", "--edges"], check=True)
        shutil.copy(f"{out}-edges/frame_00000.png", f"{pictures}/procedural-plain-edges.png")
    runs.append({"run": name, "wall_s": round(wall, 2), "bytes": rep["bytes"], "textured_triangles": rep["counts"]["textured_triangles"],
                 "d_min_m": rep["d_min"]["used_m"]})
json.dump({"benchmark": "procedural_facades", "runs": runs}, open("out/benchmarks/procedural_facades.json", "w"), indent=1)
for r in runs:
    print(f"{r['run']:8s} build {r['wall_s']:6.2f} s  total {r['bytes']['total'] / 1e6:7.2f} MB  atlases {r['bytes']['atlases'] / 1e6:6.2f} MB  "
          f"textured triangles {r['textured_triangles']}  d_min {r['d_min_m']:.0f} m")
print(f"pictures: {pictures}/procedural-*.png")
PY
