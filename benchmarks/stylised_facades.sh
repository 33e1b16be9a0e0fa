#!/usr/bin/env bash
# Benchmark: what --facades stylised costs on the synthetic town (build time,
# atlas bytes; the read stage's analysis of every facade photo), and the
# README's picture: one oblique street view in photo and in stylised facades,
# side by side.
# Usage: benchmarks/stylised_facades.sh [BUILDINGS=200] [TEXTURE_PX=512] [SIZE=1280x720] [PICTURES=out/benchmarks/stylised]
# Writes out/benchmarks/stylised_facades.json and PICTURES/stylised-facades.png
# (the README's: docs/, made with TEXTURE_PX=256 SIZE=640x360 PICTURES=docs).
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-200}"; PX="${2:-512}"; SIZE="${3:-1280x720}"; PICTURES="${4:-out/benchmarks/stylised}"
CITYATLAS="${CITYATLAS:-./build/cli/cityatlas}"
[ -n "${CITYATLAS_NO_BUILD:-}" ] || ./scripts/build > /dev/null
WORK=out/benchmarks/stylised-work; rm -rf "$WORK"; mkdir -p "$WORK" "$PICTURES"
"$CITYATLAS" synth --buildings "$N" --lod 2 --seed 1 --texture-size "$PX" -o "$WORK/town" -q > /dev/null
/usr/bin/python3 - "$WORK" "$SIZE" "$PICTURES" "$CITYATLAS" <<'PY'
import json, re, subprocess, sys, time
from PIL import Image
work, size, pictures, cityatlas = sys.argv[1:5]
runs, frames = [], []
for name in ["photo", "stylised"]:
    out = f"{work}/{name}"
    t0 = time.monotonic()
    p = subprocess.run([cityatlas, "build", f"{work}/town/town.gml", "-o", out, "--force", "--facades", name],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.monotonic() - t0
    rep = json.load(open(f"{out}/build_report.json"))
    read = next(s for s in rep["stages"] if s["name"] == "read")
    counts = re.search(r"stylised facades: (\d+) textures, (\d+) of them one colour", p.stderr)
    t = json.load(open(f"{out}/tileset.json"))
    b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
    look = [c[0], c[1] - 0.25 * hy, c[2] - hz + 8]
    cam = [c[0] - 0.1 * hx, c[1] - 0.6 * hy, c[2] - hz + 0.12 * max(hx, hy)]
    json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": [{"time_s": 0, "position": cam, "look_at": look}]},
              open(f"{work}/path.json", "w"))
    subprocess.run([cityatlas, "render", out, "--path", f"{work}/path.json", "--size", size, "--wait", "--frames", "1",
                    "-o", f"{out}-frames", "-q"], check=True)
    frames.append(Image.open(f"{out}-frames/frame_00000.png").convert("RGB"))
    runs.append({"run": name, "wall_s": round(wall, 2), "read_s": round(read["seconds"], 2), "bytes": rep["bytes"],
                 "stylised_textures": int(counts.group(1)) if counts else 0,
                 "one_colour": int(counts.group(2)) if counts else 0})
pic = Image.new("RGB", (frames[0].width * 2 + 8, frames[0].height), (255, 255, 255))
pic.paste(frames[0], (0, 0)); pic.paste(frames[1], (frames[0].width + 8, 0))
pic.save(f"{pictures}/stylised-facades.png", optimize=True)
json.dump({"benchmark": "stylised_facades", "runs": runs}, open("out/benchmarks/stylised_facades.json", "w"), indent=1)
for r in runs:
    print(f"{r['run']:8s} build {r['wall_s']:6.2f} s (read {r['read_s']:5.2f} s)  atlases {r['bytes']['atlases'] / 1e6:6.2f} MB  "
          f"stylised textures {r['stylised_textures']} ({r['one_colour']} one colour)")
print(f"picture: {pictures}/stylised-facades.png")
PY
