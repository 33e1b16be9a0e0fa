# build --procedural-facades (issue 19 item 4) on a footprint town without
# facade photos (the synthetic shapefile with its facade_tex field dropped):
#  1. the folder passes inspect; every wall triangle got a facade, and the
#     textures are the palettes' cells;
#  2. window rows equal storeys: for the 5 tallest buildings seen whole, a camera in front of
#     its longest wall (outward normal from features/bounds) looks at it with
#     its ideal set loaded; along columns that see the whole wall (the id
#     buffer: the building's pixels one run with sky above and below), runs
#     of window-coloured pixels are counted: as many as the shapefile's `levels`;
#  3. the window colour is (52, 64, 80) snapped to RGB565 as BC1 decoders
#     expand it, (49, 65, 82), in every stored cell (the folder's BC1 decoded
#     here), and within 1 LSB inside the windows (they are 4 x 4 blocks of
#     one colour, which BC1 stores exactly); each building's slab colour is
#     its cell's (the cell whose wall colour its pixels show), within 1 LSB
#     inside the bands, with as many bands as storeys;
#  4. a textured CityGML town keeps its photos: the flag textures no wall
#     there and the folder is byte-identical to the one without it.
source "$(dirname "$0")/lib.sh" "$@"
command -v ogr2ogr > /dev/null || { echo "skip: ogr2ogr (gdal-bin) not installed"; exit 77; }

"$CITYATLAS" synth -q --buildings 40 --seed 7 --texture-size 64 -o town > /dev/null
mkdir -p bare
ogr2ogr -q -select gml_id,height,eave_h,roof_h,base_h,levels,storey_h,roof_shape bare/bare.shp town/footprints.shp
"$CITYATLAS" build bare/bare.shp -o plain -q > /dev/null || fail "plain build failed"
"$CITYATLAS" build bare/bare.shp -o proc --procedural-facades > build.txt 2>&1 || { cat build.txt >&2; fail "build failed"; }
walls=$(grep -o "procedural facades on [0-9]* wall triangles" build.txt | grep -o "[0-9]*")
[ "${walls:-0}" -gt 100 ] || fail "procedural facades textured ${walls:-0} wall triangles"
"$CITYATLAS" inspect -q proc > inspect.txt 2>&1 || { cat inspect.txt >&2; fail "inspect finds defects"; }
check_eq "textures in the plain folder" 0 "$(json plain/tileset.json "len(j['extras']['cityatlas']['textures'])")"
textures=$(json proc/tileset.json "len(j['extras']['cityatlas']['textures'])")
[ "$textures" -ge 2 ] && [ "$textures" -le 8 ] || fail "expected 2..8 palette cells, got $textures"
echo "ok: $walls wall triangles textured with $textures palette cells; inspect passes"

"$PY" - proc "$CITYATLAS" <<'PY'
import json, struct, subprocess, sys, math
from PIL import Image
tiles, cityatlas = sys.argv[1], sys.argv[2]
t = json.load(open(f"{tiles}/tileset.json"))
feats = json.load(open(f"{tiles}/features/0.json"))["features"]
raw = open(f"{tiles}/features/bounds/0.bin", "rb").read()
def five(v): c = min(31, max(0, (v * 31 + 127) // 255)); return (c << 3) | (c >> 2)
def six(v): c = min(63, max(0, (v * 63 + 127) // 255)); return (c << 2) | (c >> 4)
window = (five(52), six(64), five(80))
assert window == (49, 65, 82), window
# The cells as the folder stores them: each texture's level 0 (BC1, 32 x 32)
# decoded here, by BC1's definition, independently of the code that drew them.
def expand(c): r, g, b = c >> 11 & 31, c >> 5 & 63, c & 31; return ((r << 3) | (r >> 2), (g << 2) | (g >> 4), (b << 3) | (b >> 2))
def bc1(data, w, h):
    img = [[None] * w for _ in range(h)]
    for by in range(h // 4):
        for bx in range(w // 4):
            c0, c1, bits = struct.unpack_from("<HHI", data, 8 * (by * (w // 4) + bx))
            a, b = expand(c0), expand(c1)
            if c0 > c1: pal = [a, b, tuple((2 * a[k] + b[k]) // 3 for k in range(3)), tuple((a[k] + 2 * b[k]) // 3 for k in range(3))]
            else: pal = [a, b, tuple((a[k] + b[k]) // 2 for k in range(3)), (0, 0, 0)]
            for i in range(16): img[4 * by + i // 4][4 * bx + i % 4] = pal[bits >> (2 * i) & 3]
    return img
cells = []
for e in t["extras"]["cityatlas"]["textures"]:
    block = open(f"{tiles}/{t['extras']['cityatlas']['texture_blocks'][e['block']]['uri']}", "rb").read()
    cell = bc1(block[e["offset"] + 128:], e["width"], e["height"])
    n = e["height"]
    # rows top-down: the slab in the bottom eighth, the window in the middle of the width
    cells.append({"wall": cell[0][0], "slab": cell[n - 1][0], "window": cell[n // 2][n // 2]})
assert all(c["window"] == window for c in cells), [c["window"] for c in cells]
W, H = 480, 480
checked = 0
# The tallest buildings first: more rows to count.
order = sorted(range(len(feats)), key=lambda i: -float(feats[i]["attributes"]["eave_h"]))
for fid in order[:16]:
    f = feats[fid]
    levels = int(f["attributes"]["levels"])
    mn = struct.unpack_from("<3f", raw, 32 * fid); mx = struct.unpack_from("<3f", raw, 32 * fid + 12)
    az = math.radians(struct.unpack_from("<e", raw, 32 * fid + 28)[0])
    n = (math.sin(az), math.cos(az))
    c = [(mn[k] + mx[k]) / 2 for k in range(3)]
    half = abs(n[0]) * (mx[0] - mn[0]) / 2 + abs(n[1]) * (mx[1] - mn[1]) / 2
    h = mx[2] - mn[2]
    d = half + 1.1 * h + 5
    cam = [c[0] + n[0] * d, c[1] + n[1] * d, c[2]]
    path = f"path_{fid}.json"
    json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": [
        {"time_s": 0, "position": cam, "look_at": c, "fov_deg": 60}]}, open(path, "w"))
    out = f"view_{fid}"
    subprocess.run([cityatlas, "render", tiles, "--path", path, "--size", f"{W}x{H}", "--wait", "--ids",
                    "--anisotropy", "1", "--frames", "1", "-o", out, "-q"], check=True)
    img = Image.open(f"{out}/frame_00000.png").convert("RGB")
    ids = struct.unpack(f"<{W * H}I", open(f"{out}/ids_00000.bin", "rb").read())
    px = img.load()
    NONE = 0xFFFFFFFF
    best, worst_window, columns = 0, 0, 0
    slab_rows, worst_slab = 0, 0
    # Which cell: the one whose wall colour the building's pixels show most.
    votes = {}
    for x in range(W // 2 - 60, W // 2 + 61, 4):
        for y in range(0, H, 2):
            if ids[y * W + x] != fid: continue
            for k, c in enumerate(cells):
                if max(abs(px[x, y][j] - c["wall"][j]) for j in range(3)) <= 1: votes[k] = votes.get(k, 0) + 1
    cell = cells[max(votes, key=votes.get)] if votes else None
    slab = cell["slab"] if cell else None
    for x in range(W // 2 - 60, W // 2 + 61, 4):
        # Only a column that sees the whole wall: the building's pixels one run, sky above and below.
        mine = [y for y in range(H) if ids[y * W + x] == fid]
        if not mine or mine[-1] - mine[0] + 1 != len(mine): continue
        if (mine[0] > 0 and ids[(mine[0] - 1) * W + x] != NONE) or (mine[-1] < H - 1 and ids[(mine[-1] + 1) * W + x] != NONE):
            continue
        if mine[0] == 0 or mine[-1] == H - 1: continue
        columns += 1
        rows, inside, run = 0, False, []
        for y in range(H):
            if ids[y * W + x] != fid:
                inside = False; continue
            p = px[x, y]
            is_window = max(abs(p[k] - window[k]) for k in range(3)) <= 3
            if is_window and not inside: rows += 1
            if is_window: run.append((x, y))
            inside = is_window
        best = max(best, rows)
        if slab:
            # Slab bands: runs of slab-coloured pixels (within 3), and how far inside them the colour is.
            bands, on = 0, False
            for y in mine:
                is_slab = max(abs(px[x, y][k] - slab[k]) for k in range(3)) <= 3
                if is_slab and not on: bands += 1
                if is_slab and 0 < y < H - 1 and all(max(abs(px[x, y + dy][k] - slab[k]) for k in range(3)) <= 3 for dy in (-1, 1)):
                    worst_slab = max(worst_slab, max(abs(px[x, y][k] - slab[k]) for k in range(3)))
                on = is_slab
            slab_rows = max(slab_rows, bands)
        for (x0, y0) in run:
            # well inside a window: its neighbours 2 px away are window too
            if all(ids[(y0 + dy) * W + x0] == fid and max(abs(px[x0, y0 + dy][k] - window[k]) for k in range(3)) <= 3
                   for dy in (-2, 2) if 0 <= y0 + dy < H):
                worst_window = max(worst_window, max(abs(px[x0, y0][k] - window[k]) for k in range(3)))
    if columns == 0:
        print(f"building {f['gml_id']}: no column sees the whole wall (another building is in front); skipped")
        continue
    print(f"building {f['gml_id']}: levels {levels}, window rows counted {best} ({columns} whole columns), "
          f"window colour within {worst_window}; slab bands {slab_rows}, slab colour within {worst_slab}")
    if best != levels: sys.exit(f"FAIL: {f['gml_id']}: {best} window rows, levels {levels}")
    if slab is None: sys.exit(f"FAIL: {f['gml_id']}: its wall shows no cell's wall colour")
    if slab_rows != levels: sys.exit(f"FAIL: {f['gml_id']}: {slab_rows} slab bands, levels {levels}")
    if worst_slab > 1: sys.exit(f"FAIL: {f['gml_id']}: slab pixels {worst_slab} LSB off {slab}")
    if worst_window > 1: sys.exit(f"FAIL: {f['gml_id']}: window pixels {worst_window} LSB off (49, 65, 82)")
    checked += 1
    if checked == 5: break
if checked < 3: sys.exit(f"FAIL: only {checked} buildings seen whole")
print(f"ok: window rows and slab bands equal storeys on {checked} buildings; window and slab colours within 1 LSB "
      f"of the stored cells ({len(cells)} cells decoded)")
PY

# 4. Photos kept.
"$CITYATLAS" build town/town.gml -o photo -q > /dev/null || fail "CityGML build failed"
"$CITYATLAS" build town/town.gml -o photo_proc --procedural-facades > build2.txt 2>&1 || { cat build2.txt >&2; fail "CityGML build with the flag failed"; }
grep -q "procedural facades on 0 wall triangles" build2.txt || fail "the flag textured walls of a photo-textured town: $(grep procedural build2.txt)"
diff -r -q --exclude build_report.json --exclude tileset.json photo photo_proc > diff.txt || { head diff.txt >&2; fail "the textured town changed"; }
echo "ok: a photo-textured CityGML town keeps its photos (0 walls textured, the same files)"
