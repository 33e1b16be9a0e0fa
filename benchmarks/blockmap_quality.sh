#!/usr/bin/env bash
# Issue 20's image quality of BlockMap frames along the default path (every
# frame with its ideal set loaded, --wait), against two references:
#   - the originals drawn at one sample a pixel (--mode original), as
#     cli.render_blockmaps compares: PSNR and interior holes (image_compare);
#   - the originals drawn at 4 x 4 the size and box-filtered in linear
#     light (what the scene looks like): PSNR, and interior holes against its
#     mask (a pixel covered when half its 16 samples are).
# Each for BlockMaps on, BlockMaps off (the atlas path) and the originals at
# one sample a pixel themselves, so the BlockMaps' cost is read beside what
# any one-sample rendering of the same frames scores.
# Usage: benchmarks/blockmap_quality.sh FOLDER [SIZE=480x270] [FRAMES=12] [FPS=2]
# FOLDER: built with --blockmaps complement, e.g. cityatlas build
#   out/benchmarks/synth-10000-512/town.gml -o out/benchmarks/bm-10000
#   --d-min 400 --blockmaps complement (benchmarks/build_scale.sh makes the town).
# Writes out/benchmarks/blockmap-quality-<folder name>.json and prints a table.
set -euo pipefail
cd "$(dirname "$0")/.."
TILES="${1:?usage: benchmarks/blockmap_quality.sh FOLDER [SIZE] [FRAMES] [FPS]}"
SIZE="${2:-480x270}"; FRAMES="${3:-12}"; FPS="${4:-2}"
./scripts/build > /dev/null
[ -f "$TILES/tileset.json" ] || { echo "no tile folder at $TILES" >&2; exit 1; }
NAME=$(basename "$TILES")
OUT="out/benchmarks/blockmap-quality-$NAME"; rm -rf "$OUT"; mkdir -p "$OUT"
W=${SIZE%x*}; H=${SIZE#*x}
render() {  # name size extra...
  local name=$1 size=$2; shift 2
  echo "rendering $name ($size)" >&2
  ./build/cli/cityatlas render "$TILES" --size "$size" --wait --frames "$FRAMES" --fps "$FPS" --anisotropy 1 -o "$OUT/$name" -q "$@"
}
render blockmaps "$SIZE"
render atlas "$SIZE" --blockmaps off
render originals "$SIZE" --mode original --budget 8G
render supersampled "$((4 * W))x$((4 * H))" --mode original --budget 8G
/usr/bin/python3 - "$OUT" "$W" "$H" "$FRAMES" "$TILES" "$OUT.json" ./build/tests/tools/image_compare <<'PY'
import json, subprocess, sys
import numpy as np
from PIL import Image
out, w, h, frames, tiles, result, image_compare = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5], sys.argv[6], sys.argv[7]
CLEAR = np.array([196, 218, 243])  # the clear colour (linear 0.55, 0.70, 0.90) as sRGB bytes
def load(path): return np.asarray(Image.open(path).convert("RGB"))
def linear(a):
    a = a / 255.0
    return np.where(a <= 0.04045, a / 12.92, ((a + 0.055) / 1.055) ** 2.4)
def srgb(l): return np.where(l <= 0.0031308, l * 12.92, 1.055 * l ** (1 / 2.4) - 0.055) * 255
def psnr(a, b):
    mse = ((a.astype(float) - b.astype(float)) ** 2).mean()
    return 99.0 if mse == 0 else 10 * np.log10(255.0 ** 2 / mse)
def isclear(a): return (np.abs(a.astype(int) - CLEAR) <= 2).all(-1)
def all3x3(m):
    p = np.pad(m, 1, constant_values=False)
    r = np.ones_like(m)
    for dy in range(3):
        for dx in range(3): r &= p[dy:dy + m.shape[0], dx:dx + m.shape[1]]
    return r
report = json.load(open(f"{out}/blockmaps/report.json"))
rows = []
for i in range(min(frames, len(report["frames"]))):
    name = f"frame_{i:05d}.png"
    big = load(f"{out}/supersampled/{name}")
    reference = srgb(linear(big.astype(float)).reshape(h, 4, w, 4, 3).mean(axis=(1, 3)))
    covered = (~isclear(big)).reshape(h, 4, w, 4).mean(axis=(1, 3)) >= 0.5
    row = {"frame": i, "blockmaps_drawn": report["frames"][i]["nodes_drawn"]["blockmap"],
           "atlas_nodes_drawn": report["frames"][i]["nodes_drawn"]["atlas"]}
    for run in ("blockmaps", "atlas", "originals"):
        img = load(f"{out}/{run}/{name}")
        row[run] = {"psnr_supersampled_db": round(psnr(img, reference), 2),
                    "interior_holes_supersampled": int((isclear(img) & all3x3(covered)).sum())}
        if run != "originals":
            c = json.loads(subprocess.run([image_compare, f"{out}/{run}/{name}", f"{out}/originals/{name}", "196,218,243"],
                                          check=True, capture_output=True, text=True).stdout)
            row[run].update({"psnr_one_sample_db": c["psnr_db"], "interior_holes_one_sample": c["interior_holes"],
                             "silhouette_iou_one_sample": c["silhouette_iou"]})
    rows.append(row)
json.dump({"folder": tiles, "size": f"{w}x{h}", "frames": rows}, open(result, "w"), indent=1)
print("| frame | BlockMaps / atlas nodes | PSNR vs 1-sample originals: BlockMaps, atlas | interior holes vs them | "
      "PSNR vs supersampled: BlockMaps, atlas, originals | interior holes vs its mask |")
print("|---|---|---|---|---|---|")
for r in rows:
    b, a, o = r["blockmaps"], r["atlas"], r["originals"]
    print(f"| {r['frame']} | {r['blockmaps_drawn']} / {r['atlas_nodes_drawn']} | {b['psnr_one_sample_db']:.1f}, {a['psnr_one_sample_db']:.1f} | "
          f"{b['interior_holes_one_sample']}, {a['interior_holes_one_sample']} | {b['psnr_supersampled_db']:.1f}, "
          f"{a['psnr_supersampled_db']:.1f}, {o['psnr_supersampled_db']:.1f} | {b['interior_holes_supersampled']}, "
          f"{a['interior_holes_supersampled']}, {o['interior_holes_supersampled']} |")
print(f"written {result}")
PY
