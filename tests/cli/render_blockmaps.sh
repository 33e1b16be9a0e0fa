# The client draws BlockMaps (issue 20 item 3) along the default path, headless
# on llvmpipe, against the same folder drawn with original textures only
# (--mode original, no BlockMap):
#  1. mixed frames: BlockMaps and geometry in one frame (the report counts
#     both), PSNR >= 28 dB in every frame (../shared/SEED-FEATURES.md §1.3
#     item 5), and no interior hole (image_compare's definition: a pixel
#     showing the clear colour whose 3 x 3 neighbourhood the reference
#     covers) at the default centre sampling: a wall's skirt
#     (render/core/blockmap_ray.h sideSkirt) keeps a ray down through a gap
#     or courtyard that cells widened from passing under the far wall;
#  2. every building with >= 2 px in a reference frame's id buffer is in the
#     BlockMap frame's id buffer (§1.3 item 6);
#  3. picking on BlockMap pixels: the CPU ray cast (render/core/picking.h,
#     through the BlockMap traversal) names the id buffer's building;
#  4. lenses on BlockMap pixels: solo leaves the building of interest alone
#     in the id buffer; a highlight changes its pixels and no other;
#  5. --blockmaps off draws none and loads none;
#  6. built with --blockmap-sample max (conservative cells), the same frames
#     have no interior hole at all by image_compare's definition, and
#     PSNR >= 28 dB;
#  7. built with --blockmaps replace: the frames match complement's (ids
#     differ on at most 0.5 % of the pixels), PSNR >= 28 dB; the far frame is
#     the root's BlockMap alone; --blockmaps off is refused.
#  8. --preload-levels preloads BlockMaps where they stand in.
source "$(dirname "$0")/lib.sh" "$@"
[ -n "${IMAGE_COMPARE:-}" ] || fail "IMAGE_COMPARE is not set"
CLEAR="196,218,243"  # the clear colour (linear 0.55, 0.70, 0.90) as sRGB bytes
SIZE=480x270
FRAMES=6  # at 2 fps the first four frames mix BlockMaps and leaves

"$CITYATLAS" synth -q --buildings 600 --seed 5 --texture-size 64 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o tiles --blockmaps complement --originals all > /dev/null
built=$(json tiles/build_report.json "j['blockmaps']['built']")
[ "$built" -ge 2 ] || fail "only $built BlockMap(s): the town does not test mixing"

"$CITYATLAS" render tiles --size $SIZE --wait --frames $FRAMES --fps 2 --ids --anisotropy 1 -o bm -q
"$CITYATLAS" render tiles --size $SIZE --wait --frames $FRAMES --fps 2 --ids --anisotropy 1 --mode original --budget 4G -o ref -q
"$PY" -c "import json,jsonschema,sys; jsonschema.validate(json.load(open('bm/report.json')), json.load(open(sys.argv[1])), cls=jsonschema.Draft7Validator)" \
  "$SRC/schemas/render_report.schema.json" || fail "report.json does not match its schema"
mixed=$(json bm/report.json "sum(1 for f in j['frames'] if f['nodes_drawn']['blockmap'] > 0 and f['nodes_drawn']['atlas'] + f['nodes_drawn']['originals'] > 0)")
[ "$mixed" -ge 3 ] || fail "only $mixed frames mix BlockMaps and geometry"
check_eq "frames without the root" 0 "$(json bm/report.json "j['summary']['frames_root_missing']")"
check_eq "errors" 0 "$(json bm/report.json "j['summary']['errors']")"

# PSNR (>= 28 dB in every frame) and interior holes of the frames in DIR
# against the reference's (image_compare); sets psnr_min and holes.
score_frames() {
  local dir=$1 label=$2 f name psnr covered interior
  psnr_min=99; holes=0
  for f in ref/frame_*.png; do
    name=$(basename "$f")
    read -r psnr covered interior < <("$PY" -c "import json,sys; j = json.loads(sys.argv[1]); print(j['psnr_db'], j['reference_covered'], j['interior_holes'])" \
      "$("$IMAGE_COMPARE" "$dir/$name" "$f" "$CLEAR")")
    [ "$covered" -gt 1000 ] || fail "$name: the reference shows almost nothing ($covered pixels)"
    "$PY" -c "import sys; sys.exit(0 if float(sys.argv[1]) >= 28.0 else 1)" "$psnr" || fail "$label: $name: PSNR $psnr dB < 28 dB"
    psnr_min=$("$PY" -c "import sys; print(min(float(sys.argv[1]), float(sys.argv[2])))" "$psnr_min" "$psnr")
    holes=$((holes + interior))
  done
}

# 1. PSNR and interior holes frame by frame.
score_frames bm "BlockMaps"
check_eq "interior holes over $FRAMES frames (default centre sampling)" 0 "$holes"
echo "ok: $FRAMES frames ($mixed mixing BlockMaps and geometry): PSNR against the originals min $psnr_min dB"

# 2. Every building of >= 2 px in the reference is drawn.
"$PY" - "$SIZE" <<'PY' || fail "buildings missing from BlockMap frames"
import sys, glob, os
import numpy as np
w, h = map(int, sys.argv[1].split("x"))
none = 0xFFFFFFFF
worst = 0
for ref in sorted(glob.glob("ref/ids_*.bin")):
    a = np.fromfile(ref, dtype="<u4"); b = np.fromfile(os.path.join("bm", os.path.basename(ref)), dtype="<u4")
    ids, counts = np.unique(a[a != none], return_counts=True)
    want = set(ids[counts >= 2].tolist())
    missing = want - set(np.unique(b[b != none]).tolist())
    if missing:
        print(f"{ref}: {len(missing)} of {len(want)} buildings of >= 2 px missing, e.g. {sorted(missing)[:5]}")
        sys.exit(1)
    worst = max(worst, len(want))
print(f"ok: every building of >= 2 px in the reference frames is drawn (up to {worst} a frame)")
PY

# 3. Picking on BlockMap pixels: just past the root's BlockMap distance (a
# quarter of the build's: this screen's focal length is a quarter of the
# build screen's), so the root's BlockMap alone is drawn, picks at building
# pixels of the id buffer.
"$PY" - <<'PY'
import json, math
t = json.load(open("tiles/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]
radius = math.sqrt(b[3] ** 2 + b[7] ** 2 + b[11] ** 2)  # the box's half diagonal: any box distance is at least d - radius
d = radius + 0.3 * t["root"]["extras"]["cityatlas"]["min_distance_m"]
u = [-0.6, -0.6, 0.53]; n = math.sqrt(sum(v * v for v in u))
eye = [c[k] + d * u[k] / n for k in range(3)]
keys = [{"time_s": 0, "position": eye, "look_at": c, "label": "far"}, {"time_s": 1, "position": eye, "look_at": c, "label": "far"}]
json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": keys}, open("far.json", "w"))
PY
"$CITYATLAS" render tiles --path far.json --size $SIZE --wait --frames 1 --ids --anisotropy 1 -o far -q
check_eq "the far frame: nodes drawn (atlas, originals, blockmap)" "0 0 1" "$(json far/report.json "' '.join(str(j['frames'][0]['nodes_drawn'][k]) for k in ('atlas', 'originals', 'blockmap'))")"
"$PY" - "$SIZE" <<'PY'
import sys, json
import numpy as np
w, h = map(int, sys.argv[1].split("x"))
ids = np.fromfile("far/ids_00000.bin", dtype="<u4").reshape(h, w)
picks = []
# Pixels whose four neighbours show the same building (buildings are a few
# pixels wide here): a pick at the pixel centre is not at an edge.
for y in range(1, h - 1):
    for x in range(1, w - 1):
        v = ids[y, x]
        if v != 0xFFFFFFFF and ids[y - 1, x] == v and ids[y + 1, x] == v and ids[y, x - 1] == v and ids[y, x + 1] == v:
            picks.append([x + 0.5, y + 0.5])
picks = picks[::max(1, len(picks) // 40)][:40]
assert len(picks) >= 10, f"only {len(picks)} pixels to pick"
json.dump(picks, open("picks.json", "w"))
PY
"$CITYATLAS" render tiles --path far.json --size $SIZE --wait --frames 1 --ids --anisotropy 1 --picks picks.json -o picked -q
"$PY" - <<'PY' || fail "picking disagrees with the id buffer on BlockMap pixels"
import json
p = json.load(open("picked/report.json"))["picks"]
agree = sum(1 for q in p if q.get("feature") is not None and q["feature"] == q.get("id_buffer"))
print(f"ok: {agree} of {len(p)} picks on the root's BlockMap name the id buffer's building")
assert agree == len(p), [q for q in p if q.get("feature") != q.get("id_buffer")][:3]
PY

# 4. Lenses on the root's BlockMap (the far frame).
"$PY" - "$SIZE" <<'PY'
import sys, json
import numpy as np
w, h = map(int, sys.argv[1].split("x"))
ids = np.fromfile("far/ids_00000.bin", dtype="<u4")
v, n = np.unique(ids[ids != 0xFFFFFFFF], return_counts=True)
poi = int(v[np.argmax(n)])  # the building with the most pixels
path = json.load(open("far.json"))
for name, lens in (("solo", {"building": poi, "solo": True}), ("highlight", {"highlight": [poi]})):
    json.dump(dict(path, lens=lens), open(f"far-{name}.json", "w"))
open("poi.txt", "w").write(str(poi))
PY
for lens in solo highlight; do
  "$CITYATLAS" render tiles --path far-$lens.json --size $SIZE --wait --frames 1 --ids --anisotropy 1 -o far-$lens -q
done
"$PY" - "$SIZE" <<'PY' || fail "lenses on BlockMap pixels"
import sys
import numpy as np
from PIL import Image
w, h = map(int, sys.argv[1].split("x"))
poi = int(open("poi.txt").read())
none = 0xFFFFFFFF
ids = np.fromfile("far/ids_00000.bin", dtype="<u4")
solo = np.fromfile("far-solo/ids_00000.bin", dtype="<u4")
assert set(np.unique(solo[solo != none]).tolist()) == {poi}, f"solo: ids {np.unique(solo[solo != none])[:5]}"
assert (solo == poi).sum() >= (ids == poi).sum(), "solo: the building lost pixels"
hl = np.fromfile("far-highlight/ids_00000.bin", dtype="<u4")
assert (hl == ids).all(), "highlight: the id buffer changed"
a = np.asarray(Image.open("far/frame_00000.png").convert("RGB")).reshape(-1, 3).astype(int)
b = np.asarray(Image.open("far-highlight/frame_00000.png").convert("RGB")).reshape(-1, 3).astype(int)
changed = (np.abs(a - b).max(axis=1) > 2)
assert changed[ids == poi].mean() > 0.9, f"highlight: {changed[ids == poi].mean():.2f} of the building's pixels changed"
assert not changed[ids != poi].any(), f"highlight: {changed[ids != poi].sum()} other pixels changed"
print(f"ok: lenses on the root's BlockMap: solo leaves building {poi} alone ({(solo == poi).sum()} px), "
      f"a highlight changes its {(ids == poi).sum()} px and no other")
PY

# 5. Off: no BlockMap drawn or loaded.
"$CITYATLAS" render tiles --size $SIZE --wait --frames 4 --fps 2 --anisotropy 1 --blockmaps off -o off -q
check_eq "--blockmaps off: BlockMaps drawn" 0 "$(json off/report.json "sum(f['nodes_drawn']['blockmap'] for f in j['frames'])")"
check_eq "--blockmaps off: BlockMaps requested" 0 "$(json off/report.json "sum(f['requests']['blockmap'] for f in j['frames'])")"
echo "ok: --blockmaps off draws and loads none"

# 6. Conservative cells: no interior hole either.
"$CITYATLAS" build -q town/town.gml -o tiles-max --blockmaps complement --originals all --blockmap-sample max > /dev/null
"$CITYATLAS" render tiles-max --size $SIZE --wait --frames $FRAMES --fps 2 --anisotropy 1 -o bm-max -q
score_frames bm-max "--blockmap-sample max"
check_eq "--blockmap-sample max: interior holes over $FRAMES frames" 0 "$holes"
echo "ok: --blockmap-sample max: no interior hole, PSNR min $psnr_min dB"

# 7. replace: the levels BlockMaps cover completely have nothing else. The
# same frames as complement's where both draw the same (a node's BlockMap
# switches at its own distance, so closer than it both refine to the
# children), PSNR >= 28 dB against the originals, the ids of every building
# of >= 2 px; the far frame is the root's BlockMap alone (all the root has);
# BlockMaps off is refused in one line.
"$CITYATLAS" build -q town/town.gml -o tiles-rep --blockmaps replace --originals all > /dev/null
replaced=$(json tiles-rep/build_report.json "j['blockmaps']['replaced']['levels']")
[ "$replaced" -ge 1 ] || fail "replace left no level to its BlockMaps"
"$CITYATLAS" render tiles-rep --size $SIZE --wait --frames $FRAMES --fps 2 --ids --anisotropy 1 -o rep -q
check_eq "replace: errors, frames without the root" "0 0" "$(json rep/report.json "str(j['summary']['errors']) + ' ' + str(j['summary']['frames_root_missing'])")"
score_frames rep "replace"
same_min=99
for f in bm/frame_*.png; do
  same=$("$PY" -c "import json,sys; print(json.loads(sys.argv[1])['psnr_db'])" "$("$IMAGE_COMPARE" "rep/$(basename "$f")" "$f" "$CLEAR")")
  same_min=$("$PY" -c "import sys; print(min(float(sys.argv[1]), float(sys.argv[2])))" "$same_min" "$same")
done
"$PY" - "$same_min" <<'PY' || fail "replace draws what complement draws differently"
import sys, glob, os
import numpy as np
# The id buffers: where complement drew a replaced node's geometry (closer
# than its BlockMap's distance, farther than its own min distance: LOD2
# roofs measure above a texel), replace draws its children instead; count.
differ = total = 0
for a in sorted(glob.glob("bm/ids_*.bin")):
    x = np.fromfile(a, dtype="<u4"); y = np.fromfile(os.path.join("rep", os.path.basename(a)), dtype="<u4")
    differ += int((x != y).sum()); total += x.size
share = differ / total
print(f"ok: replace against complement: ids differ on {100 * share:.2f} % of the pixels, PSNR >= {float(sys.argv[1]):.1f} dB")
sys.exit(0 if share <= 0.005 else 1)
PY
check_eq "replace: the far frame draws (atlas, originals, blockmap)" "0 0 1" \
  "$("$CITYATLAS" render tiles-rep --path far.json --size $SIZE --wait --frames 1 -o rep-far -q && json rep-far/report.json "' '.join(str(j['frames'][0]['nodes_drawn'][k]) for k in ('atlas', 'originals', 'blockmap'))")"
set +e
"$CITYATLAS" render tiles-rep --blockmaps off --frames 1 -o rep-off -q > rep-off.txt 2>&1; rc=$?
set -e
check_eq "replace with --blockmaps off: exit code, lines" "2 1" "$rc $(wc -l < rep-off.txt)"
grep -q "built with --blockmaps replace" rep-off.txt || { cat rep-off.txt >&2; fail "the refusal does not say why"; }
echo "ok: replace ($replaced levels): PSNR against the originals min $psnr_min dB; $(cat rep-off.txt)"

# 8. Preloading (--preload-levels) keeps a node's BlockMap resident, not its
# geometry and atlases, where BlockMaps are drawn: the level chosen is the
# deepest whose stand-ins fit a quarter of the budget, recounted here from
# tileset.json for both settings, with a budget that holds the upper levels'
# BlockMaps and not their geometry (levels 0 to the tree's deepest inner
# level, at most 2).
read -r levels budget want_on want_off < <("$PY" - <<'PY'
import json
t = json.load(open("tiles/tileset.json"))
def nodes(n, level=0):
    yield n, level
    for ch in n.get("children", []): yield from nodes(ch, level + 1)
geo, bm = {}, {}
for n, level in nodes(t["root"]):
    ca = n["extras"]["cityatlas"]
    g = sum(L["geometry"]["bytes"] + (L["atlas"]["bytes"] if L.get("atlas") else 0) for L in ca["layers"].values())
    geo[level] = geo.get(level, 0) + g
    bm[level] = bm.get(level, 0) + (ca["blockmap"]["bytes"] if "blockmap" in ca else g)
top = min(2, max(geo))
budget = 4 * sum(bm[l] for l in range(top + 1)) + 4
def chosen(by_level):
    level, total = -1, 0
    for l in range(top + 1):
        total += by_level[l]
        if total > budget // 4: break
        level = l
    return level
assert top >= 1 and chosen(geo) < top, "the upper levels' geometry fits too: the town does not separate the two"
print(top, budget, chosen(bm), chosen(geo))
PY
)
for run in on off; do
  "$CITYATLAS" render tiles --frames 1 --size 160x90 --anisotropy 1 --preload-levels "$levels" --budget "$budget" --blockmaps $run -o preload-$run -q
done
check_eq "--preload-levels $levels: the level preloaded, BlockMaps on and off" "$want_on $want_off" \
  "$(json preload-on/report.json "j['settings']['preload_level']") $(json preload-off/report.json "j['settings']['preload_level']")"
