# Large originals split into overlapping tiles (issue 18's H6; papers/000
# §4.6, papers/004 §2; tiles/texture_tiles.h), end to end on a town whose
# roofs all carry one 1202 x 532 orthophoto (more than two 512 atlases),
# built with --originals all (at this size the atlases hold it exactly):
# - the tileset lists the orthophoto whole (unwritten: no roof repeats it)
#   and then as 6 clamped tiles, in consecutive numbers, with the sizes an
#   independent computation of the grid gives (512 cores, 16 texels of
#   overlap, clipped at the image border), and `inspect` passes; with
#   the default (--split-originals off) it is one texture;
# - a leaf needs only the tiles under its own roofs: some leaves' texture
#   blocks lack some tiles (with every original whole, each leaf loads all of
#   it), and the overlap costs less than 30 % more bytes;
# - the tiles look like the whole texture: a render drawing the leaves'
#   originals (the roofs seen from just above) equals the unsplit build's
#   within 1 LSB on every pixel. Both builds use --uv-bits 20: at the default
#   the original coordinates are quantized within 1/8 texel, differently for
#   a tile than for the whole texture, which moves 0.1 % of the pixels by up
#   to 7 LSB;
# - a sharded build (4 shards) passes inspect, its leaves list only some
#   tiles, and shards in worker processes give the same folder;
# - the 3D Tiles export embeds each tile's texels, not the whole image.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth -q --lod 1 --buildings 30 --seed 8 --texture-size 32 --orthophoto world-file -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o on --d-min 40 --originals all --uv-bits 20 --split-originals on > /dev/null
"$CITYATLAS" build -q town/town.gml -o off --d-min 40 --originals all --uv-bits 20 > /dev/null
"$CITYATLAS" inspect on > inspect.txt || { tail -20 inspect.txt >&2; fail "inspect finds defects in the split folder"; }
echo "ok: inspect passes ($(tail -1 inspect.txt))"
"$PY" - <<'PY' || fail "tiles in the tileset (above)"
import json, sys
from PIL import Image
w, h = Image.open("town/textures/orthophoto.png").size
core, overlap = 512, 16
cols, rows = -(-w // core), -(-h // core)
want = []
for r in range(rows):
    for c in range(cols):
        x0, y0 = max(0, c * core - overlap), max(0, r * core - overlap)
        x1, y1 = min(w, (c + 1) * core + overlap), min(h, (r + 1) * core + overlap)
        want.append((x1 - x0, y1 - y0))
on = json.load(open("on/tileset.json"))["extras"]["cityatlas"]
off = json.load(open("off/tileset.json"))["extras"]["cityatlas"]
bad = False
def check(ok, what):
    global bad
    print(("ok: " if ok else "FAIL: ") + what); bad |= not ok
big = [i for i, t in enumerate(off["textures"]) if (t["width"], t["height"]) == (w, h)]
check(len(big) == 1, f"unsplit: the orthophoto is one {w}x{h} texture")
k = big[0]
tiles = on["textures"][k + 1:k + 1 + len(want)]
check((on["textures"][k]["width"], on["textures"][k]["height"]) == (w, h), "split: the whole texture keeps its number (for triangles that repeat it)")
check([(t["width"], t["height"]) for t in tiles] == want, f"split: {len(want)} tiles after it {want}")
check(all(t["wrap"] == "clamp" for t in tiles), "the tiles are sampled clamped")
check(on["textures"][k]["block"] == -1, "no roof repeats the orthophoto: the whole texture is not written")
check(len(on["textures"]) == len(off["textures"]) + len(want), "the other textures keep their entries, numbers after the tiles shift")
# Which tiles each leaf needs: its texture blocks' tile entries.
def leaf_tiles(doc, first, count):
    out = []
    def walk(node):
        if node.get("children"):
            for c in node["children"]:
                walk(c)
            return
        blocks = set(node["extras"]["cityatlas"].get("texture_blocks", []))
        out.append({i for i in range(first, first + count) if doc["textures"][i]["block"] in blocks})
    walk(json.load(open("on/tileset.json"))["root"])
    return out
per_leaf = leaf_tiles(on, k + 1, len(want))
check(all(per_leaf) and any(len(s) < len(want) for s in per_leaf),
      f"the tiles in each leaf's blocks (some leaves lack some): {[sorted(s) for s in per_leaf]}")
ton, toff = on["totals"]["bytes"]["textures"], off["totals"]["bytes"]["textures"]
check(ton < toff * 1.3, f"original bytes {ton} split, {toff} whole (the overlap costs < 30 %)")
# A camera 6 m above the highest roof at the town's centre, looking down
# (10 degrees off the vertical): close enough for originals, and every roof
# magnified, so only mip levels the overlap keeps equal are sampled.
t = json.load(open("on/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]
top = c[2] + b[11]
json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": [
    {"time_s": 0, "position": [c[0] + 3, c[1] - 3, top + 6], "look_at": [c[0] + 3, c[1], top - 10]}]}, open("down.json", "w"))
sys.exit(1 if bad else 0)
PY
for f in on off; do
  "$CITYATLAS" render $f --path down.json --frames 1 --size 320x240 --wait --anisotropy 1 -o render_$f -q
done
"$PY" - <<'PY' || fail "the split render differs (above)"
import json, sys
from PIL import Image, ImageChops
a = Image.open("render_on/frame_00000.png").convert("RGB")
b = Image.open("render_off/frame_00000.png").convert("RGB")
worst = max(hi for lo, hi in ImageChops.difference(a, b).getextrema())
drawn = [json.load(open(f"render_{f}/report.json"))["frames"][0]["nodes_drawn"]["originals"] for f in ("on", "off")]
print(f"leaves drawing originals: {drawn}; largest difference {worst} LSB")
sys.exit(0 if drawn[0] > 0 and drawn == drawn[::-1] and worst <= 1 else 1)
PY
echo "ok: the roofs drawn from the tiles equal the whole orthophoto's within 1 LSB"

# Sharded: the shards report the tiles their leaves use (manifest leaf_tiles)
# and the merge plans the blocks from them; in the build's process or in
# worker processes, the same folder.
"$CITYATLAS" build -q town/town.gml -o sharded --d-min 40 --originals all --split-originals on --shard-triangles 200 --workers 0 > /dev/null
"$CITYATLAS" build -q town/town.gml -o sharded2 --d-min 40 --originals all --split-originals on --shard-triangles 200 --workers 2 > /dev/null
check_eq "shards" 4 "$(json sharded/build_report.json "j['shards']['count']")"
"$CITYATLAS" inspect sharded > inspect_sharded.txt || { tail -20 inspect_sharded.txt >&2; fail "inspect finds defects in the sharded folder"; }
diff -rq -x build_report.json sharded sharded2 > shard.diff || { cat shard.diff >&2; fail "in-process and worker shards differ"; }
"$PY" - <<'PY' || fail "the sharded build's tiles (above)"
import json
t = json.load(open("sharded/tileset.json"))
tiles = [i for i, x in enumerate(t["extras"]["cityatlas"]["textures"]) if x["wrap"] == "clamp"]
leaves = []
def walk(n):
    if n.get("children"):
        for c in n["children"]:
            walk(c)
    else:
        blocks = set(n["extras"]["cityatlas"].get("texture_blocks", []))
        leaves.append({i for i in tiles if t["extras"]["cityatlas"]["textures"][i]["block"] in blocks})
walk(t["root"])
print(f"{len(tiles)} tiles; blocks of leaves hold tiles {[sorted(s) for s in leaves]}")
assert len(tiles) == 6 and any(leaves) and any(len(s) < 6 for s in leaves if s)
PY
echo "ok: 4 shards: inspect passes, leaves list only some tiles, worker processes give the same folder"

# At --d-min 1500 some leaves' atlases hold the orthophoto below its
# resolution, so the export writes close-range tiles that draw the originals.
"$CITYATLAS" build -q town/town.gml -o web --d-min 1500 --split-originals on --format both --web-textures png > /dev/null
"$PY" - <<'PY' || fail "3D Tiles tile images (above)"
import glob, json, os, sys
from PIL import Image
t = json.load(open("web/tileset.json"))["extras"]["cityatlas"]["textures"]
ortho = Image.open("town/textures/orthophoto.png").convert("RGB")
core, overlap = 512, 16
first = min(i for i, x in enumerate(t) if x["wrap"] == "clamp")  # the first tile
checked = 0
for p in glob.glob("web/3dtiles/textures/*.png"):
    k = int(os.path.basename(p).split(".")[0])
    img = Image.open(p).convert("RGB")
    if t[k]["wrap"] != "clamp":
        continue
    tile = k - first
    c, r = tile % 3, tile // 3
    box = (max(0, c * core - overlap), max(0, r * core - overlap), min(ortho.width, (c + 1) * core + overlap), min(ortho.height, (r + 1) * core + overlap))
    if img.tobytes() != ortho.crop(box).tobytes():
        print(f"FAIL: {p} is not the orthophoto's texels {box}"); sys.exit(1)
    checked += 1
print(f"{checked} tile images in the export, each exactly its texels of the orthophoto")
sys.exit(0 if checked >= 2 else 1)
PY
echo "ok: the 3D Tiles export embeds the tiles' texels"
