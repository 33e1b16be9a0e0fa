# `cityatlas render` headless on Mesa llvmpipe (EGL, no display) over a built
# synthetic town:
# - the report matches its schema; the default path (no --path) renders;
# - images are right: a path from a pedestrian view to an overview, rendered
#   with the atlas tree and with original textures only (from the same build
#   with --originals all: the atlases hold many textures exactly and write no
#   original for them), both waiting for the ideal set: per-frame PSNR and no
#   facade pixel missing (interior holes); a leaf without originals at street
#   level, drawn from its atlas, against the same leaf drawn from its originals;
# - the budget holds under streaming: real time over HTTP from nginx with a
#   budget of 1/10 of the atlas and texture bytes: resident <= budget in every
#   frame, the root always there (no untextured frame), refinement converging;
# - errors: missing, truncated and corrupted blocks render coarser and are
#   reported; a dead server and a missing folder are one clear line, exit 1.
source "$(dirname "$0")/lib.sh" "$@"
[ -n "${IMAGE_COMPARE:-}" ] || fail "IMAGE_COMPARE is not set"

"$CITYATLAS" synth --buildings 30 --seed 3 --texture-size 128 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles-all --d-min 100 --originals all -q > /dev/null
check_eq "--originals all changes no atlas" "$(cd tiles && cat atlas/*/*.dds | sha256sum)" "$(cd tiles-all && cat atlas/*/*.dds | sha256sum)"
CLEAR="196,218,243"  # the clear colour (linear 0.55, 0.70, 0.90) as sRGB bytes

# A path from eye height at the town's southern edge up to an overview (tileset.json's root box).
"$PY" - <<'PY'
import json
t = json.load(open("tiles/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
z0 = c[2] - hz
keys = [
  {"time_s": 0, "position": [c[0] - 0.3 * hx, c[1] - hy - 5, z0 + 1.7], "look_at": [c[0] - 0.3 * hx, c[1], z0 + 5], "label": "pedestrian"},
  {"time_s": 4, "position": [c[0], c[1] - hy - 60, z0 + 60], "look_at": [c[0], c[1], z0], "label": "oblique"},
  {"time_s": 8, "position": [c[0], c[1] - 1.5 * hy, z0 + 1.6 * max(hx, hy)], "look_at": [c[0], c[1], z0], "label": "overview"}]
json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": keys}, open("path.json", "w"), indent=1)
# The streaming path: the same flight, a teleport back to the street, and a hold there.
street = dict(keys[0]); street.update(time_s=8.5, cut=True, label="teleport")
hold = dict(keys[0]); hold.update(time_s=11, label="street")
json.dump({"interpolation": "linear", "frame_rate": 4, "keyframes": keys + [street, hold]}, open("stream.json", "w"), indent=1)
PY
"$PY" -c "import json,jsonschema,sys; jsonschema.validate(json.load(open('path.json')), json.load(open(sys.argv[1])), cls=jsonschema.Draft7Validator)" \
  "$SRC/schemas/camera_path.schema.json" || fail "path.json does not match the camera path schema"

# --- The default path and the report schema.
"$CITYATLAS" render tiles --size 240x160 --wait --frames 12 --fps 1 -o default -q
"$PY" -c "import json,jsonschema,sys; jsonschema.validate(json.load(open('default/report.json')), json.load(open(sys.argv[1])), cls=jsonschema.Draft7Validator)" \
  "$SRC/schemas/render_report.schema.json" || fail "report.json does not match its schema"
check_eq "default path frames" "12" "$(ls default/frame_*.png | wc -l)"
check_eq "default path: frames without the root" "0" "$(json default/report.json "j['summary']['frames_root_missing']")"
check_eq "default path: every frame drew something" "True" "$(json default/report.json "all(f['triangles'] > 0 for f in j['frames'])")"

# --- Images are right: atlas tree vs original textures, both with the ideal set loaded.
"$CITYATLAS" render tiles --path path.json --size 320x240 --wait --anisotropy 1 -o atlas -q
"$CITYATLAS" render tiles-all --path path.json --size 320x240 --wait --anisotropy 1 --mode original --budget 4G -o original -q
psnr_min=99; psnr_sum=0; n=0
for f in original/frame_*.png; do
  name=$(basename "$f")
  r=$("$IMAGE_COMPARE" "atlas/$name" "$f" "$CLEAR")
  psnr=$("$PY" -c "import json,sys; print(json.loads(sys.argv[1])['psnr_db'])" "$r")
  interior=$("$PY" -c "import json,sys; print(json.loads(sys.argv[1])['interior_holes'])" "$r")
  covered=$("$PY" -c "import json,sys; print(json.loads(sys.argv[1])['reference_covered'])" "$r")
  [ "$covered" -gt 1000 ] || fail "$name: the reference shows almost nothing ($covered pixels): the path misses the town"
  [ "$interior" -eq 0 ] || fail "$name: $interior facade pixels show the clear colour with the atlas tree"
  # 30 dB: issue 7's bar for the atlas tree against the original textures.
  # Both are BC1 and trilinear; what remains is resampling (atlas vs mip chain).
  "$PY" -c "import sys; sys.exit(0 if float(sys.argv[1]) >= 30.0 else 1)" "$psnr" || fail "$name: PSNR $psnr dB < 30 dB"
  psnr_min=$("$PY" -c "import sys; print(min(float(sys.argv[1]), float(sys.argv[2])))" "$psnr_min" "$psnr")
  psnr_sum=$("$PY" -c "import sys; print(float(sys.argv[1]) + float(sys.argv[2]))" "$psnr_sum" "$psnr")
  n=$((n + 1))
  echo "  $name: PSNR $psnr dB, interior holes $interior"
done
# Picking: the building at the image centre is the same whether the atlas tree's
# merged node geometry or the leaves' own geometry is drawn.
picks=$("$PY" -c "
import json
a = json.load(open('atlas/report.json'))['frames']; o = json.load(open('original/report.json'))['frames']
both = [(x['centre_pick'], y['centre_pick']) for x, y in zip(a, o) if x['centre_pick'] and y['centre_pick']]
print(len(both), sum(x['feature'] == y['feature'] for x, y in both))")
read -r picked same <<<"$picks"
[ "$picked" -ge 3 ] || fail "picking: only $picked frames hit a building at the centre"
check_eq "picking: same building in both modes (of $picked frames)" "$picked" "$same"
echo "ok: atlas tree vs original textures over $n frames: PSNR min $psnr_min dB, mean $("$PY" -c "print(round($psnr_sum / $n, 2))") dB, no missing facade pixel"

# --- A leaf whose atlas holds every texture at full resolution (no texture
# blocks) at street level: drawn from its atlas, as the client does at any
# distance, against the same leaf drawn from the originals the other build
# wrote. The copies start on the textures' own 4x4 blocks, so BC1 encodes the
# same blocks: what differs is filtering near region borders.
"$PY" - <<'PY' || fail "no exact leaf with a facade to look at"
import json, math
t = json.load(open("tiles/tileset.json"))
best = None
def walk(tile):
    global best
    ca = tile["extras"]["cityatlas"]
    if "children" not in tile and not ca["texture_blocks"] and "opaque" in ca["layers"] and ca["layers"]["opaque"]["atlas"]:
        b = tile["boundingVolume"]["box"]
        if best is None or b[11] > best[11]: best = b  # the tallest: most facade in view
    for c in tile.get("children", []): walk(c)
walk(t["root"])
assert best, "every leaf has texture blocks"
c, hx, hy, hz = best[:3], best[3], best[7], best[11]
z0 = c[2] - hz
eye = [c[0], c[1] - hy - 6, z0 + 1.7]  # 6 m in front of the box's southern side, at eye height
keys = [{"time_s": 0, "position": eye, "look_at": [c[0], c[1], z0 + hz], "label": "street"},
        {"time_s": 1, "position": eye, "look_at": [c[0], c[1], z0 + hz], "label": "street"}]
json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": keys}, open("street.json", "w"), indent=1)
print(f"exact leaf: box centre {c}, half-size {hx:.1f} x {hy:.1f} x {hz:.1f} m")
PY
"$CITYATLAS" render tiles --path street.json --size 320x240 --wait --anisotropy 1 -o street_atlas -q
"$CITYATLAS" render tiles-all --path street.json --size 320x240 --wait --anisotropy 1 --mode original --budget 4G -o street_original -q
r=$("$IMAGE_COMPARE" street_atlas/frame_00000.png street_original/frame_00000.png "$CLEAR")
psnr=$("$PY" -c "import json,sys; print(json.loads(sys.argv[1])['psnr_db'])" "$r")
covered=$("$PY" -c "import json,sys; print(json.loads(sys.argv[1])['reference_covered'])" "$r")
[ "$covered" -gt 20000 ] || fail "street view of the exact leaf: only $covered pixels show the town"
# 35 dB: above the 30 dB the whole path must reach, since the atlas here is the
# originals' own texels; tests/tiles/test_tileset.cpp checks texel for texel
# that it is within 0.5 dB of the original DDS.
"$PY" -c "import sys; sys.exit(0 if float(sys.argv[1]) >= 35.0 else 1)" "$psnr" || fail "street view of an exact leaf: PSNR $psnr dB < 35 dB"
echo "ok: a leaf without originals at street level: its atlas against its originals, PSNR $psnr dB ($covered pixels)"

# --- The budget holds under streaming: real time over HTTP from nginx, a slow link.
NGINX_SERVE="$SRC/tests/render/nginx/nginx_serve.sh"
set +e; PORT=$(bash "$NGINX_SERVE" start "$PWD/tiles" "$PWD/nginx" 4m); rc=$?; set -e
if [ $rc -eq 0 ]; then
  trap 'bash "$NGINX_SERVE" stop "$PWD/nginx" || true' EXIT
  budget=$(json tiles/tileset.json "(j['extras']['cityatlas']['totals']['bytes']['atlases'] + j['extras']['cityatlas']['totals']['bytes']['textures']) // 10")
  "$CITYATLAS" render "http://127.0.0.1:$PORT/" --path stream.json --size 320x240 --budget "$budget" --anisotropy 1 -o stream -q
  check_eq "streaming: frames over the budget" "0" "$(json stream/report.json "sum(f['resident_bytes'] + f['pinned_bytes'] > $budget for f in j['frames'])")"
  check_eq "streaming: the feature bounds are pinned inside the budget" \
    "$(json tiles/tileset.json "sum(t['bounds']['bytes'] for t in j['extras']['cityatlas']['features']['tables'])")" \
    "$(json stream/report.json "max(f['pinned_bytes'] for f in j['frames'])")"
  check_eq "streaming: frames without the root (untextured)" "0" "$(json stream/report.json "j['summary']['frames_root_missing']")"
  check_eq "streaming: load errors" "0" "$(json stream/report.json "j['summary']['errors']")"
  check_eq "streaming: needed blocks missing at the end of the hold" "0" "$(json stream/report.json "j['frames'][-1]['refinement']['needed_missing']")"
  check_eq "streaming: refinement happened (some frame was coarse or waiting)" "True" \
    "$(json stream/report.json "any(f['refinement']['ideal_missing'] > 0 for f in j['frames'])")"
  teleport=$(json stream/report.json "j['summary']['teleports'][0]['seconds_to_ideal_set']")
  needed=$(json stream/report.json "j['summary']['teleports'][0]['seconds_to_needed_set']")
  [ "$teleport" != "None" ] || fail "streaming: the teleport never reached a complete ideal set"
  [ "$needed" != "None" ] || fail "streaming: the teleport never had its needed blocks"
  "$PY" -c "import sys; sys.exit(0 if float(sys.argv[1]) <= float(sys.argv[2]) else 1)" "$needed" "$teleport" ||
    fail "streaming: needed blocks ($needed s) after the whole ideal set ($teleport s)"
  requests=$(grep -c '"GET ' nginx/access.log || true)
  echo "ok: streaming over nginx at 4 MB/s with a budget of $budget bytes: $requests requests, teleport to street level: needed blocks after $needed s, the whole ideal set after $teleport s"
  bash "$NGINX_SERVE" stop "$PWD/nginx"; trap - EXIT
elif [ $rc -eq 77 ]; then
  echo "SKIPPED (part): nginx is not installed (Debian: nginx-light); streaming over HTTP not tested"
else
  fail "nginx_serve.sh could not start nginx (exit $rc)"
fi

# --- Errors: damaged blocks render coarser and are reported; fatal ones are one line.
rm -rf damaged; cp -r tiles-all damaged
"$PY" - <<'PY'
import json, os
t = json.load(open("damaged/tileset.json"))
leaves = []
def walk(tile):
    if "children" not in tile: leaves.append(tile)
    for c in tile.get("children", []): walk(c)
walk(t["root"])
layers = [l for leaf in leaves for l in [leaf["extras"]["cityatlas"]["layers"].get("opaque")] if l and l["atlas"]]
os.remove("damaged/" + layers[0]["atlas"]["uri"])                                   # missing
with open("damaged/" + layers[1]["atlas"]["uri"], "r+b") as f: f.seek(84); f.write(b"XXXX")  # corrupt FourCC
g = "damaged/" + layers[2]["geometry"]["uri"]; os.truncate(g, os.path.getsize(g) // 2)       # truncated
open("damaged/" + t["extras"]["cityatlas"]["texture_blocks"][0]["uri"], "wb").close()       # empty texture block
print(layers[0]["atlas"]["uri"], layers[1]["atlas"]["uri"], layers[2]["geometry"]["uri"], file=open("damaged.txt", "w"))
PY
"$CITYATLAS" render damaged --mode original --budget 4G --wait --wait-timeout 30 --frames 3 --fps 1 --size 160x120 -o damaged_frames -q ||
  fail "render fails on a folder with damaged blocks"
errors=$(json damaged_frames/report.json "j['summary']['errors']")
[ "$errors" -ge 4 ] || fail "damaged folder: $errors errors reported, expected 4"
for uri in $(cat damaged.txt); do
  grep -q "$uri" damaged_frames/report.json || fail "damaged folder: the report does not name $uri"
done
echo "ok: a folder with a missing, a corrupted, a truncated and an empty block renders and reports $errors errors"
"$CITYATLAS" render damaged --wait --frames 2 --fps 1 --size 160x120 -o damaged_atlas -q || fail "atlas mode fails on the damaged folder"
check_eq "damaged folder, atlas mode: frames without the root" "0" "$(json damaged_atlas/report.json "j['summary']['frames_root_missing']")"

expect 1 "127.0.0.1:9" -- render http://127.0.0.1:9/ --frames 1 -q
expect 1 "no such folder" -- render no_such_folder --frames 1 -q
expect 1 "not a cityatlas tile folder" -- render town --frames 1 -q
expect 2 "--size" -- render tiles --size 12x9000000
expect 2 "--budget" -- render tiles --budget lots
expect 2 "--edge-strength" -- render tiles --edges --edge-strength 1.5

# --edges: the same frames, only darker, on the buildings' outlines and creases (GlTest checks the rule per pixel).
"$CITYATLAS" render tiles --path path.json --size 320x240 --wait --anisotropy 1 -o edges -q --edges
"$PY" - atlas edges <<'PY' || fail "render --edges does more than darken edge pixels"
import glob, os, sys
from PIL import Image
darker = total = 0
for f in sorted(glob.glob(f"{sys.argv[1]}/frame_*.png")):
    a = Image.open(f).convert("RGB").tobytes()
    b = Image.open(os.path.join(sys.argv[2], os.path.basename(f))).convert("RGB").tobytes()
    assert all(y <= x + 1 for x, y in zip(a, b)), f"{f}: a pixel got brighter with --edges"
    darker += sum(1 for k in range(0, len(a), 3) if b[k] + b[k + 1] + b[k + 2] + 30 < a[k] + a[k + 1] + a[k + 2])
    total += len(a) // 3
assert 0.002 * total < darker < 0.3 * total, f"{darker} of {total} pixels darkened"
print(f"ok: render --edges darkens {darker} of {total} pixels ({100 * darker / total:.1f} %), brightens none")
PY

# `cityatlas view`: without a display one clear line; under Xvfb a few frames and a clean exit.
set +e; env -u DISPLAY -u WAYLAND_DISPLAY "$CITYATLAS" view tiles --frames 2 > /dev/null 2> view.err; rc=$?; set -e
[ $rc -eq 1 ] || fail "view without a display: exit $rc, expected 1"
grep -q "no display" view.err || { cat view.err >&2; fail "view without a display: no clear message"; }
echo "ok: view without a display: $(head -1 view.err)"
if command -v xvfb-run > /dev/null; then
  xvfb-run -a -s "-screen 0 800x600x24" "$CITYATLAS" view tiles --frames 20 --no-vsync --width 640 --height 400 ||
    fail "view under Xvfb failed"
  echo "ok: view ran 20 frames under Xvfb"
fi
