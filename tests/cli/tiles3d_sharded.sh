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
#  3. (cli.build_slurm: one shard through plan, shard job and merge exports
#     the in-process build's 3dtiles/ byte for byte);
#  4. with --computed (a plan, shards and a merge even at one shard) the
#     export validates, and computed textures (issue 19) are
#     EXT_structural_metadata property textures: per node one NEAREST grey
#     PNG on the photo-textured primitives only (with an alpha layer, both
#     layers' images side by side and each layer's atlas uvs mapped to its
#     place as TEXCOORD_1),
#     equal to the native BC4 file's level 0 as an independent BC4 decoder
#     (here, by its definition) reads it, offset and scale giving the range;
#  5. --format 3dtiles through shards leaves no native file and no PNG.
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

# 4.
"$CITYATLAS" build -q town/town.gml -o planned --d-min 30 --format both --computed sky_view:directions=8 > /dev/null \
  || fail "a --computed --format both build failed"
validate_export planned "one shard with computed textures"

"$PY" - planned <<'PY' || fail "the property textures do not carry the native computed textures"
import io, json, os, struct, sys
from PIL import Image
folder = sys.argv[1]
native = json.load(open(f"{folder}/tileset.json"))
computed = native["extras"]["cityatlas"]["computed"]
assert [c["name"] for c in computed] == ["sky_view"], computed
def walk(t, out):
    e = t["extras"]["cityatlas"]; out[e["id"]] = e
    for k in t.get("children", []): walk(k, out)
    return out
tiles = walk(native["root"], {})
def bc4(data, w, h):  # BC4 (RGTC1) level 0 by its definition, independent of the writer's decoder
    out = [[0] * w for _ in range(h)]
    bw = (w + 3) // 4
    for b in range(bw * ((h + 3) // 4)):
        blk = data[8 * b:8 * b + 8]
        r0, r1 = blk[0], blk[1]
        pal = [r0, r1] + ([((7 - i) * r0 + i * r1) / 7 for i in range(1, 7)] if r0 > r1
                          else [((5 - i) * r0 + i * r1) / 5 for i in range(1, 5)] + [0, 255])
        bits = int.from_bytes(blk[2:8], "little")
        for k in range(16):
            x, y = (b % bw) * 4 + k % 4, (b // bw) * 4 + k // 4
            if x < w and y < h: out[y][x] = pal[(bits >> (3 * k)) & 7]
    return out
checked = exact = texels = 0
worst = 0.0
close_checked = packed_checked = remapped = 0
def accessor(doc, bin_, i):
    a = doc["accessors"][i]; v = doc["bufferViews"][a["bufferView"]]
    o = v.get("byteOffset", 0) + a.get("byteOffset", 0)
    return struct.unpack_from(f"<{2 * a['count']}f", bin_, o)
for node, e in sorted(tiles.items()):
    uris = {}
    for layer in ("opaque", "alpha"):
        files = (e["layers"].get(layer) or {}).get("computed", [])
        if files and (files[0] or {}).get("uri"): uris[layer] = files[0]["uri"]
    # The layout (tiles3d_writer.cpp propertyTexture): with the alpha layer, both side by side (the opaque
    # one, a column repeating its last, the alpha one) over TEXCOORD_1; else the opaque one alone.
    decoded = {}
    for layer, uri in uris.items():
        dds = open(f"{folder}/{uri}", "rb").read()
        h, w = struct.unpack_from("<II", dds, 12)
        decoded[layer] = (w, h, bc4(dds[148:], w, h))
    packed = "alpha" in decoded
    carrying = [l for l in ("opaque", "alpha") if l in decoded and (packed or l == "opaque")]
    place = {}
    if packed:
        w0, h0 = decoded["opaque"][:2] if "opaque" in decoded else (0, 0)
        w1, h1 = decoded["alpha"][:2]
        x1 = w0 + 1 if "opaque" in decoded else 0
        W, H = x1 + w1, max(h0, h1)
        want = [[0.0] * W for _ in range(H)]
        if "opaque" in decoded:
            for y in range(h0):
                want[y][:w0] = decoded["opaque"][2][y]
                want[y][w0] = decoded["opaque"][2][y][w0 - 1]
            place["opaque"] = (0, w0, h0)
        for y in range(h1): want[y][x1:x1 + w1] = decoded["alpha"][2][y]
        place["alpha"] = (x1, w1, h1)
    elif carrying:
        W, H, want = decoded["opaque"]
    for glb in (f"{node}.glb", f"{node}_originals.glb"):
        close = glb.endswith("_originals.glb")
        if close and not os.path.exists(f"{folder}/3dtiles/tiles/{glb}"): continue
        b = open(f"{folder}/3dtiles/tiles/{glb}", "rb").read()
        n = struct.unpack_from("<I", b, 12)[0]
        doc, bin_ = json.loads(b[20:20 + n]), b[20 + n + 8:]
        meta = doc["extensions"]["EXT_structural_metadata"]
        prop = meta["schema"]["classes"]["surface"]["properties"]["sky_view"]
        assert prop["componentType"] == "UINT8" and prop["normalized"] and prop["offset"] == computed[0]["range"][0] \
            and abs(prop["offset"] + prop["scale"] - computed[0]["range"][1]) < 1e-12, prop
        textures = meta.get("propertyTextures", [])
        # The carrying layers' photo-textured primitives reference the property texture (a close-range
        # tile's originals too); the other layer's and material-coloured ones do not.
        prims = doc["meshes"][0]["primitives"]
        def layer_of(p):
            name = doc["materials"][p["material"]]["name"]
            layer, what = name.split(" ", 1)
            return layer if what == "atlas" or (close and what.startswith("original texture")) else None
        refs = {tuple(p.get("extensions", {}).get("EXT_structural_metadata", {}).get("propertyTextures", []))
                for p in prims if layer_of(p) in carrying}
        assert all("EXT_structural_metadata" not in p.get("extensions", {}) for p in prims if layer_of(p) not in carrying), \
            f"{glb}: a primitive of a layer without computed values, or material-coloured, has a property texture"
        if not carrying:
            assert not textures, f"{glb}: property texture without a computed file"
            continue
        assert refs == {(0,)} and len(textures) == 1, f"{glb}: photo primitives reference {refs}"
        pt = textures[0]
        uv = pt["properties"]["sky_view"].get("texCoord", 0)
        assert pt["class"] == "surface" and uv == (1 if close or packed else 0), (glb, pt)
        assert all(f"TEXCOORD_{uv}" in p["attributes"] for p in prims if layer_of(p) in carrying), f"{glb}: no TEXCOORD_{uv}"
        if packed and not close:  # each layer's uvs mapped to its place: u1 = (x + u0 w) / W, v1 = v0 h / H
            for p in prims:
                if layer_of(p) not in carrying: continue
                x, w, h = place[layer_of(p)]
                a0, a1 = accessor(doc, bin_, p["attributes"]["TEXCOORD_0"]), accessor(doc, bin_, p["attributes"]["TEXCOORD_1"])
                for k in range(0, len(a0), 2):
                    assert abs(a1[k] - (x + a0[k] * w) / W) < 1e-6 and abs(a1[k + 1] - a0[k + 1] * h / H) < 1e-6, \
                        f"{glb}: vertex {k // 2} of the {layer_of(p)} layer at {a1[k:k + 2]}, expected its place"
                    remapped += 1
        tex = doc["textures"][pt["properties"]["sky_view"]["index"]]
        sampler = doc["samplers"][tex["sampler"]]
        assert sampler["magFilter"] == sampler["minFilter"] == 9728, f"{glb}: property texture not NEAREST: {sampler}"
        v = doc["bufferViews"][doc["images"][tex["source"]]["bufferView"]]
        png = Image.open(io.BytesIO(bin_[v.get("byteOffset", 0):v.get("byteOffset", 0) + v["byteLength"]]))
        assert png.mode == "L", png.mode
        assert png.size == (W, H), f"{glb}: {png.size} against {W}x{H}"
        got = png.load()
        for y in range(H):
            for x in range(W):
                d = abs(got[x, y] - want[y][x])
                worst = max(worst, d)
                exact += d < 0.5 + 1e-9
                texels += 1
        checked += 1
        close_checked += close
        packed_checked += packed
listed = json.load(open(f"{folder}/3dtiles/tileset.json"))["asset"]["extras"]["cityatlas"]["computed"]
assert [(c["name"], c["property"], c["range"]) for c in listed] == [("sky_view", "sky_view", computed[0]["range"])], listed
assert close_checked >= 5, f"only {close_checked} close-range tiles carry property textures"
assert packed_checked >= 5 and remapped >= 100, f"only {packed_checked} tiles with both layers ({remapped} uvs)"
print(f"ok: {checked} property textures ({close_checked} of close-range tiles; {packed_checked} with both layers side by side, "
      f"{remapped} uvs mapped to their layer's place; sky_view, NEAREST, on the photo primitives only) equal their nodes' BC4 level 0: "
      f"every texel within {worst:.2f} of a code ({exact} of {texels} round to it; BC4 interpolates in fractions of a code)")
PY

# 5.
for native in tileset.json geometry atlas textures features computed; do
  [ ! -e "png/$native" ] || fail "a sharded --format 3dtiles left the native $native"
done
[ -z "$(find png -name '*.png' -not -path 'png/.cityatlas-cache/*' -not -path 'png/3dtiles/*')" ] || fail "atlas PNGs left in the folder"
echo "ok: a sharded --format 3dtiles folder holds no native file and no atlas PNG outside its shard cache"
