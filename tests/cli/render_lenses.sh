# Information lenses in `cityatlas render` (issue 18; papers/003; the spec's
# L1 occluder sets and L2), from the camera path's "lens" object, checked
# through the id buffer:
# - the occluders of a building of interest are exactly the set an
#   independent Python computation finds from the bounds files (the
#   view-axis test of papers/003 eq. 3.18 over a 3x3x3 grid of the
#   building's box, and on 20 cameras around it the near-viewer tests as
#   well: spherical (eq. 3.16), cylindrical, and viewer height (eq. 3.17));
# - discard: no pixel carries an occluder's id (exact), and the building
#   shows at least 99 % of the pixels it has drawn alone (solo); without the
#   lens it shows fewer than 90 % (the camera really is behind others);
# - x-ray: the building shows the same >= 99 % through the x-ray faces, and
#   the picture differs from the discard one (the faces are drawn);
# - flatten: occluders keep pixels only near the ground and the building
#   shows >= 90 %;
# - colour by height and a sphere lens change the picture and nothing else
#   (ids equal); a lens naming a building that does not exist is one line.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth --buildings 30 --seed 3 --texture-size 64 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 -q > /dev/null
W=320; H=240
"$PY" - "$SRC/tests/cli" <<'PY'
import json, struct, sys
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, sys.argv[1])
import lens_oracle
t = json.load(open("tiles/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
z0 = c[2] - hz
boxes = []
for table in t["extras"]["cityatlas"]["features"]["tables"]:
    raw = open("tiles/" + table["bounds"]["uri"], "rb").read()
    boxes += [struct.unpack_from("<6f", raw, 32 * i) for i in range(len(raw) // 32)]
# The building nearest the town's centre, seen from the southern street at eye height.
poi = min(range(len(boxes)), key=lambda i: ((boxes[i][0] + boxes[i][3]) / 2 - c[0]) ** 2 + ((boxes[i][1] + boxes[i][4]) / 2 - c[1]) ** 2)
pc = [(boxes[poi][k] + boxes[poi][k + 3]) / 2 for k in range(3)]
cam = [pc[0], c[1] - hy - 5, z0 + 1.7]
keys = [{"time_s": 0, "position": cam, "look_at": [pc[0], pc[1], z0 + 8]}, {"time_s": 1, "position": cam, "look_at": [pc[0], pc[1], z0 + 8]}]
def path(name, lens):
    json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": keys, **({"lens": lens} if lens else {})},
              open(f"{name}.json", "w"), indent=1)
path("plain", None)
path("solo", {"building": poi, "solo": True})
path("discard", {"building": poi, "occlusion": "discard"})
path("xray", {"building": poi, "occlusion": "xray", "xray_falloff": 0.5})
path("flatten", {"building": poi, "occlusion": "flatten"})
path("height", {"colour_by": "height", "highlight": [poi]})
path("sphere", {"shape": "sphere", "centre": pc, "radius_m": 25})
path("missing", {"building": len(boxes), "solo": True})
# The occluders, independently (tests/cli/lens_oracle.py).
occ = sorted(lens_oracle.occluders(boxes, poi, cam))
json.dump({"poi": poi, "occluders": occ}, open("expected.json", "w"))
# L1 on 20 cameras: a ring around the building at several heights and
# distances, each frame one camera (a key per second at 1 frame a second),
# with the spherical test (papers/003 eq. 3.16) on as well.
import math, random
rng = random.Random(20)
ring = []
for i in range(20):
    a = 2 * math.pi * i / 20
    d = rng.uniform(50, 160)
    p = [pc[0] + d * math.cos(a), pc[1] + d * math.sin(a), z0 + rng.uniform(1.7, 40)]
    ring.append({"time_s": i, "position": p, "look_at": pc})
for test in ("sphere", "cylinder", "viewer_height"):
    json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": ring,
               "lens": {"building": poi, "occlusion": "discard", "sphere_radius_m": 30.5, "near_test": test}},
              open(f"ring_{test}.json", "w"), indent=1)
json.dump({"boxes": boxes, "poi": poi}, open("ring_expected_inputs.json", "w"))
print(f"building {poi}, {len(occ)} occluders: {occ}")
PY
for test in sphere cylinder viewer_height; do
  "$CITYATLAS" render tiles --path ring_$test.json --size 160x120 --wait --anisotropy 1 -o ring_$test -q
done
"$PY" - "$SRC/tests/cli" <<'PY' || fail "L1: occluder sets on 20 cameras differ (above)"
import json, sys
sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, sys.argv[1])
import lens_oracle
e = json.load(open("ring_expected_inputs.json")); boxes, poi = e["boxes"], e["poi"]
failed = False
near_sets = {}
for test in ("sphere", "cylinder", "viewer_height"):
    frames = json.load(open(f"ring_{test}/report.json"))["frames"]
    bad, total, by_near = 0, 0, 0
    near_sets[test] = []
    for f in frames:
        cam = f["camera"]["position"]
        want = lens_oracle.occluders(boxes, poi, cam, 30.5, test)
        near_sets[test].append(want - lens_oracle.occluders(boxes, poi, cam))
        by_near += len(near_sets[test][-1])
        got = set(f["lens_occluder_ids"])
        total += len(want)
        if got != want:
            bad += 1
            print(f"FAIL: {test}: frame {f['frame']}: occluders {sorted(got)}, expected {sorted(want)}")
    print(f"{test}: {len(frames)} cameras, {total} occluders in all ({by_near} by the near-viewer test): {len(frames) - bad} sets equal")
    failed |= bad > 0 or len(frames) != 20 or by_near == 0
# The three near-viewer tests pick different buildings on these cameras (so each one is checked).
for a, b in (("sphere", "cylinder"), ("sphere", "viewer_height")):
    if near_sets[a] == near_sets[b]:
        print(f"FAIL: {a} and {b} find the same buildings near the viewer on every camera"); failed = True
sys.exit(1 if failed else 0)
PY
echo "ok: L1: the occluder sets of 20 cameras equal the independent computation (sphere, cylinder, viewer height)"
for lens in plain solo discard xray flatten height sphere; do
  "$CITYATLAS" render tiles --path $lens.json --size ${W}x${H} --wait --anisotropy 1 --ids -o $lens -q
done
expect 2 "lens building 30 does not exist" -- render tiles --path missing.json --frames 1 -o missing -q
"$PY" - "$W" "$H" <<'PY' || fail "lenses (above)"
import json, struct, sys
from PIL import Image
w, h = int(sys.argv[1]), int(sys.argv[2])
e = json.load(open("expected.json")); poi, occ = e["poi"], set(e["occluders"])
bad = False
def check(ok, what):
    global bad
    print(("ok: " if ok else "FAIL: ") + what); bad |= not ok
def ids(name): return struct.unpack(f"<{w * h}I", open(f"{name}/ids_00001.bin", "rb").read())
def rgb(name): return Image.open(f"{name}/frame_00001.png").convert("RGB").tobytes()
def report(name): return json.load(open(f"{name}/report.json"))["frames"][1]
solo = sum(i == poi for i in ids("solo"))
plain = sum(i == poi for i in ids("plain"))
check(solo > 500, f"the building alone covers {solo} pixels")
check(plain < 0.9 * solo, f"without a lens it shows {plain} of them: others hide it")
check(set(report("discard")["lens_occluder_ids"]) == occ and report("discard")["lens_occluders"] == len(occ) and occ,
      f"occluders: {report('discard')['lens_occluder_ids']} in the report, {sorted(occ)} by the independent test")
d = ids("discard")
check(not any(i in occ for i in d), "discard: no pixel carries an occluder's id")
check(sum(i == poi for i in d) >= 0.99 * solo, f"discard: the building shows {sum(i == poi for i in d)} of {solo}")
x = ids("xray")
check(sum(i == poi for i in x) >= 0.99 * solo, f"x-ray: the building shows {sum(i == poi for i in x)} of {solo} (faces keep no ids)")
check(rgb("xray") != rgb("discard"), "x-ray: the faces are drawn")
f = ids("flatten")
check(sum(i == poi for i in f) >= 0.9 * solo, f"flatten: the building shows {sum(i == poi for i in f)} of {solo}")
check(sum(i in occ for i in f) < 0.2 * sum(i in occ for i in ids("plain")),
      f"flatten: occluders keep {sum(i in occ for i in f)} of their {sum(i in occ for i in ids('plain'))} pixels")
for name in ("height", "sphere"):
    check(ids(name) == ids("plain") and rgb(name) != rgb("plain"), f"{name}: the same ids, another picture")
sys.exit(1 if bad else 0)
PY
