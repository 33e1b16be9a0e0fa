# The 3D Tiles export of a sharded build (issue 17: a city is sharded, and
# web teams want 3D Tiles of it). The shards keep their atlases as PNG, the
# merge names them by the whole tree's node numbers and the export runs after
# the merge, its features read back from the folder's feature tables.
#  1. a town cut into at least 4 shards, --format both: the export validates
#     (official 3D Tiles 1.1 schemas, Khronos glTF validator), is the same
#     with shards in this process and in worker processes, and every building
#     of the native feature tables is in some leaf's property table;
#  2. every atlas embedded (--web-textures png: lossless) is its own node's:
#     against the native DDS of the same node decoded by Pillow (an
#     independent BC1/BC3 decoder), its PSNR is the one the native tileset
#     records for that DDS (within 0.5 dB); another node's atlas fails that;
#  3. a one-shard build through plan, shard and merge (forced by --computed)
#     exports the same 3dtiles/ as the in-process build, byte for byte
#     (tileset.json aside from its tilesetVersion: the build hash);
#  4. --format 3dtiles through shards leaves no native file and no PNG.
source "$(dirname "$0")/lib.sh" "$@"
ensure_gltf_validator
"$CITYATLAS" synth -q --buildings 60 --seed 5 --texture-size 64 -o town > /dev/null

# 1.
"$CITYATLAS" build -q town/town.gml -o workers --d-min 30 --shard-triangles 1000 --workers 2 --format both > /dev/null \
  || fail "a sharded build with --format both failed"
"$CITYATLAS" build -q town/town.gml -o inproc --d-min 30 --shard-triangles 1000 --workers 0 --format both > /dev/null \
  || fail "a sharded build with --format both (--workers 0) failed"
shards=$(json workers/build_report.json "j['shards']['count']")
[ "$shards" -ge 4 ] || fail "expected at least 4 shards, got $shards"
validate_export workers "$shards shards, --format both"
diff -r -q --exclude build_report.json inproc workers > diff.txt || { head diff.txt >&2; fail "in-process and worker shards export differently"; }
echo "ok: --workers 0 and --workers 2 give the same folders, 3dtiles/ included ($(find workers/3dtiles -type f | wc -l) files)"
"$CITYATLAS" inspect -q workers > /dev/null || fail "the native half of a sharded --format both does not inspect clean"

"$PY" - workers <<'PY' || fail "some building of the feature tables is in no leaf's property table"
import glob, json, os, struct, sys
folder = sys.argv[1]
native = json.load(open(f"{folder}/tileset.json"))
ids = []
for t in native["extras"]["cityatlas"]["features"]["tables"]:
    ids += [f["gml_id"] for f in json.load(open(f"{folder}/{t['uri']}"))["features"]]
def glb(path):
    b = open(path, "rb").read()
    n = struct.unpack_from("<I", b, 12)[0]
    return json.loads(b[20:20 + n]), b[20 + n + 8:]
def leaves(t):
    kids = t.get("children", [])
    return [t] if not kids or kids[0]["geometricError"] == 0 else [x for k in kids for x in leaves(k)]
seen = set()
for leaf in leaves(json.load(open(f"{folder}/3dtiles/tileset.json"))["root"]):
    if "content" not in leaf: continue
    doc, bin_ = glb(f"{folder}/3dtiles/{leaf['content']['uri']}")
    table = doc["extensions"]["EXT_structural_metadata"]["propertyTables"][0]
    col = table["properties"]["gml_id"]
    def view(i):
        v = doc["bufferViews"][i]; o = v.get("byteOffset", 0)
        return bin_[o:o + v["byteLength"]]
    values, offsets = view(col["values"]), view(col["stringOffsets"])
    off = struct.unpack(f"<{table['count'] + 1}I", offsets)
    seen |= {values[off[k]:off[k + 1]].decode() for k in range(table["count"])}
missing = set(ids) - seen
assert not missing and len(ids) == 60, f"{len(missing)} of {len(ids)} missing, e.g. {sorted(missing)[:3]}"
print(f"ok: all {len(ids)} buildings of the native feature tables are in the leaves' property tables")
PY

# 2.
"$CITYATLAS" build -q town/town.gml -o png --d-min 30 --shard-triangles 1000 --format 3dtiles --web-textures png > /dev/null \
  || fail "a sharded --format 3dtiles --web-textures png build failed"
"$CITYATLAS" build -q town/town.gml -o native --d-min 30 --shard-triangles 1000 > /dev/null || fail "the native twin failed"
"$PY" - png native <<'PY' || fail "an embedded atlas is not its node's"
import io, json, math, struct, sys
from PIL import Image
web, native = sys.argv[1], sys.argv[2]
def walk(t, out):
    e = t["extras"]["cityatlas"]; out[e["id"]] = e
    for k in t.get("children", []): walk(k, out)
    return out
tiles = walk(json.load(open(f"{native}/tileset.json"))["root"], {})
def psnr(a, b):
    a, b = a.convert("RGB").tobytes(), b.convert("RGB").tobytes()
    mse = sum((x - y) ** 2 for x, y in zip(a, b)) / len(a)
    return math.inf if mse == 0 else 10 * math.log10(255 ** 2 / mse)
checked, worst, other = 0, 0.0, None
for node, e in sorted(tiles.items()):
    b = open(f"{web}/3dtiles/tiles/{node}.glb", "rb").read()
    n = struct.unpack_from("<I", b, 12)[0]
    doc, bin_ = json.loads(b[20:20 + n]), b[20 + n + 8:]
    for m in doc.get("materials", []):
        layer, what = m["name"].split(" ", 1)
        if what != "atlas": continue
        tex = doc["textures"][m["pbrMetallicRoughness"]["baseColorTexture"]["index"]]
        v = doc["bufferViews"][doc["images"][tex["source"]]["bufferView"]]
        png = Image.open(io.BytesIO(bin_[v.get("byteOffset", 0):v.get("byteOffset", 0) + v["byteLength"]]))
        atlas = e["layers"][layer]["atlas"]
        dds = Image.open(f"{native}/{atlas['uri']}")
        assert png.size == dds.size, f"node {node} {layer}: embedded {png.size}, native DDS {dds.size}"
        p = psnr(png, dds)
        assert p >= 25 and abs(p - atlas["psnr_db"]) <= 0.5, f"node {node} {layer}: PSNR {p:.2f} dB, recorded {atlas['psnr_db']}"
        worst = max(worst, abs(p - atlas["psnr_db"]))
        checked += 1
        if other is None and node > 0: other = (node, png)
assert checked >= 20, f"only {checked} atlases embedded"
# The bar is not vacuous: the root's DDS against another node's embedded atlas, resized to fit.
root = Image.open(f"{native}/{tiles[0]['layers']['opaque']['atlas']['uri']}")
wrong = psnr(other[1].resize(root.size), root)
assert wrong < 20, f"node {other[0]}'s atlas against the root's DDS: {wrong:.2f} dB"
print(f"ok: {checked} embedded atlases each match their own node's DDS (PSNR within {worst:.2f} dB of the recorded one); another node's: {wrong:.1f} dB")
PY

# 3.
"$CITYATLAS" build -q town/town.gml -o single --d-min 30 --format both > /dev/null || fail "the in-process build failed"
"$CITYATLAS" build -q town/town.gml -o planned --d-min 30 --format both --computed sky_view:directions=8 > /dev/null \
  || fail "the one-shard plan/shard/merge build failed"
check_eq "the planned build's shards" 1 "$(json planned/build_report.json "j['shards']['count']")"
diff -r -q --exclude tileset.json single/3dtiles planned/3dtiles > diff.txt || { head diff.txt >&2; fail "plan/shard/merge exports other files than the in-process build"; }
"$PY" - single/3dtiles/tileset.json planned/3dtiles/tileset.json <<'PY' || fail "the two tileset.json differ beyond tilesetVersion"
import json, sys
a, b = (json.load(open(p)) for p in sys.argv[1:])
for j in (a, b): j["asset"].pop("tilesetVersion")
assert a == b
PY
echo "ok: one shard through plan, shard and merge exports the in-process build's 3dtiles/ byte for byte ($(find planned/3dtiles -type f | wc -l) files)"

# 4.
for native in tileset.json geometry atlas textures features computed; do
  [ ! -e "png/$native" ] || fail "a sharded --format 3dtiles left the native $native"
done
[ -z "$(find png -name '*.png' -not -path 'png/.cityatlas-cache/*' -not -path 'png/3dtiles/*')" ] || fail "atlas PNGs left in the folder"
echo "ok: a sharded --format 3dtiles folder holds no native file and no atlas PNG outside its shard cache"
