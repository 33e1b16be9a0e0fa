# `cityatlas render --ids`: the id buffer (issue 18's groundwork, the spec's
# S1 and S3) against the client's CPU ray cast, its oracle (spec L0):
# - every frame written gets ids_NNNNN.bin, width x height uint32, top row
#   first; its ids are building indices of the town or 0xFFFFFFFF;
# - "none" and the clear colour agree pixel for pixel (nothing drawn there);
# - at 10,000 random pixels of an oblique frame the id buffer names the
#   building the ray cast through the pixel centre hits, at >= 99.9 % of
#   them, and every disagreement lies within 1 px of an edge between ids
#   (the ray and the rasteriser round a silhouette differently);
# - the picks' id_buffer field (one pixel read back, what `view` picks by)
#   equals the file's value at that pixel; the report with them matches its
#   schema.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth --buildings 30 --seed 3 --texture-size 64 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 -q > /dev/null
W=320; H=240
"$PY" - "$W" "$H" <<'PY'
import json, random, sys
w, h = int(sys.argv[1]), int(sys.argv[2])
t = json.load(open("tiles/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
z0 = c[2] - hz
keys = [
  {"time_s": 0, "position": [c[0] - 0.3 * hx, c[1] - hy - 5, z0 + 1.7], "look_at": [c[0] - 0.3 * hx, c[1], z0 + 5]},
  {"time_s": 2, "position": [c[0], c[1] - hy - 60, z0 + 60], "look_at": [c[0], c[1], z0]}]
json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": keys}, open("path.json", "w"), indent=1)
rng = random.Random(18)
pixels = rng.sample([(x, y) for y in range(h) for x in range(w)], 10000)
json.dump([[x + 0.5, y + 0.5] for x, y in pixels], open("picks.json", "w"))
PY

"$CITYATLAS" render tiles --path path.json --size ${W}x${H} --wait --anisotropy 1 --ids --picks picks.json -o out -q
"$PY" -c "import json,jsonschema,sys; jsonschema.validate(json.load(open('out/report.json')), json.load(open(sys.argv[1])), cls=jsonschema.Draft7Validator)" \
  "$SRC/schemas/render_report.schema.json" || fail "report.json (with picks and id_buffer) does not match its schema"
check_eq "id buffers written" "3" "$(ls out/ids_*.bin | wc -l)"
"$PY" - "$W" "$H" <<'PY' || fail "the id buffer and the ray cast disagree (above)"
import json, struct, sys
from PIL import Image
w, h = int(sys.argv[1]), int(sys.argv[2])
NONE = 0xFFFFFFFF
features = json.load(open("town/truth.json"))["buildings"]
features = features if isinstance(features, int) else len(features)
bad = False
def check(ok, what):
    global bad
    print(("ok: " if ok else "FAIL: ") + what)
    bad |= not ok
for f in (0, 1, 2):
    raw = open(f"out/ids_{f:05d}.bin", "rb").read()
    check(len(raw) == 4 * w * h, f"frame {f}: {len(raw)} bytes = 4 x {w} x {h}")
    ids = struct.unpack(f"<{w * h}I", raw)
    distinct = set(ids) - {NONE}
    check(all(i < features for i in distinct), f"frame {f}: {len(distinct)} building ids, all below {features}")
    rgb = Image.open(f"out/frame_{f:05d}.png").convert("RGB").tobytes()
    clear = (196, 218, 243)
    mismatch = sum(1 for p in range(w * h) if (ids[p] == NONE) != (tuple(rgb[3 * p:3 * p + 3]) == clear))
    check(mismatch == 0, f"frame {f}: 'no id' pixels are exactly the clear-colour pixels ({mismatch} differ)")
ids = struct.unpack(f"<{w * h}I", open("out/ids_00002.bin", "rb").read())
check(len(set(ids) - {NONE}) >= 10, f"the oblique frame shows {len(set(ids) - {NONE})} buildings (>= 10)")
picks = json.load(open("out/report.json"))["picks"]
agree = 0; off_edge = []
for p in picks:
    x, y = int(p["x"]), int(p["y"])
    here = ids[y * w + x]
    check_id = p["id_buffer"] if p["id_buffer"] is not None else NONE
    if check_id != here:
        check(False, f"pick ({x}, {y}): id_buffer {check_id} but the file holds {here}")
    ray = p["feature"] if p["hit"] else NONE
    if ray == here:
        agree += 1
        continue
    around = {ids[yy * w + xx] for yy in range(max(0, y - 1), min(h, y + 2)) for xx in range(max(0, x - 1), min(w, x + 2))}
    if len(around) == 1:
        off_edge.append((x, y, here, ray))
share = agree / len(picks)
check(share >= 0.999, f"id buffer == ray cast at {agree} of {len(picks)} pixels ({100 * share:.2f} %, >= 99.9 %)")
check(not off_edge, f"disagreements away from an id edge: {off_edge[:5]}")
sys.exit(1 if bad else 0)
PY

# --ids without a folder to write into is a usage error.
expect 2 "--ids needs -o" -- render tiles --ids --frames 1 -q
