# What one merge takes is capped (tiles/node_geometry.h: 64 node budgets, at
# most 2,097,152 triangles): above it whole buildings are left out, smallest
# first, before the merge is built, and the tileset says so. The default cap
# is far above any town a test can build, so --node-triangles 64 (a cap of
# 4,096 triangles) makes a 300-building town's root merge (~6,000
# triangles at --d-min 200) go over it:
#  1. the report counts the capped node layers and their buildings, and the
#     summary says so;
#  2. every capped layer's children held more than the cap, and no layer
#     whose children held more is uncapped; every building is still drawn
#     at the root or listed as dropped there;
#  3. each tile's geometricError covers its layers' errors (error *
#     corner_factor) and is at most its parent's, in the native tileset and
#     the 3D Tiles export (which validates: schema and glTF validator);
#     inspect (the tileset's own checker) finds no defect;
#  4. a sharded build (4+ shards in 2 workers; its merge caps the levels
#     above the shards, a shard those below) holds to 2. and 3. too, and its
#     shards built in this process (--workers 0) give the same folder.
source "$(dirname "$0")/lib.sh" "$@"
ensure_gltf_validator

"$CITYATLAS" synth -q --buildings 300 --seed 7 --texture-size 32 -o town > /dev/null
"$CITYATLAS" build town/town.gml -o capped --node-triangles 64 --d-min 200 --format both > build.txt 2> /dev/null ||
  fail "the capped build failed"
capped=$(json capped/build_report.json "j['counts']['node_layers_capped']")
left_out=$(json capped/build_report.json "j['counts']['buildings_left_out_over_cap']")
[ "$capped" -ge 1 ] || fail "no merge went over the cap of 4,096 triangles: the test does not exercise it"
[ "$left_out" -ge 1 ] || fail "$capped capped node layers left no building out"
grep -q "merges capped: $capped node layers left out $left_out buildings, smallest first .* at most 4096 triangles" build.txt ||
  { cat build.txt >&2; fail "the summary does not report the capped merges"; }
echo "ok: $capped node layers capped, $left_out buildings left out (report and summary)"

consistent() {  # consistent FOLDER: 2. and 3. on its tileset.json and its 3D Tiles export
  "$PY" - "$1/tileset.json" "$1/3dtiles/tileset.json" town/truth.json <<'PY' || fail "$1: the capped tileset is inconsistent"
import json, sys
t = json.load(open(sys.argv[1]))
cap = 64 * t["extras"]["cityatlas"]["build"]["node_triangles"]
focal = t["extras"]["cityatlas"]["build"]["focal_px"]
bad, capped = [], 0
def walk(tile, parent_error):
    global capped
    n = tile["extras"]["cityatlas"]
    ge = tile["geometricError"]
    if ge > parent_error * (1 + 1e-12):
        bad.append(f"node {n['id']}: geometricError {ge} above its parent's {parent_error}")
    corner = n["min_distance_m"] / focal / n["world_texel_m"]  # min_distance / focal per metre of texel
    for name, L in n["layers"].items():
        if ge < L["geometric_error_m"] * corner * (1 - 1e-12):
            bad.append(f"node {n['id']} {name}: geometricError {ge} does not cover its error {L['geometric_error_m']} m")
        children = sum(k["extras"]["cityatlas"]["layers"].get(name, {}).get("triangles", 0) for k in tile.get("children", []))
        if L.get("left_out_over_cap"):
            capped += 1
            if children <= cap: bad.append(f"node {n['id']} {name}: capped with {children} triangles in its children (cap {cap})")
        elif children > cap:
            bad.append(f"node {n['id']} {name}: {children} triangles in its children (cap {cap}) and nothing left out")
    for k in tile.get("children", []): walk(k, ge)
walk(t["root"], t["geometricError"])
if capped == 0: bad.append("no layer says left_out_over_cap")
root = t["root"]["extras"]["cityatlas"]["features"]
buildings = json.load(open(sys.argv[3]))["buildings"]
if root["count"] + len(root["dropped"]) != buildings:
    bad.append(f"the root draws {root['count']} and drops {len(root['dropped'])} of {buildings} buildings")
x = json.load(open(sys.argv[2]))
def walk3(tile, parent_error):
    if tile["geometricError"] > parent_error * (1 + 1e-12):
        bad.append(f"3D Tiles: a tile's geometricError {tile['geometricError']} above its parent's {parent_error}")
    for k in tile.get("children", []): walk3(k, tile["geometricError"])
walk3(x["root"], x["geometricError"])
print("\n".join(bad[:10]), file=sys.stderr)
sys.exit(1 if bad else 0)
PY
}
consistent capped
echo "ok: capped layers only where their children held more than the cap; errors covered and monotone; every building drawn or dropped at the root"
"$CITYATLAS" inspect -q capped > inspect.txt 2>&1 || { tail -5 inspect.txt >&2; fail "inspect finds defects in the capped folder"; }
validate_export capped "the capped build's 3D Tiles export"

"$CITYATLAS" build -q town/town.gml -o sharded --node-triangles 64 --d-min 200 --format both --shard-triangles 1500 \
  --workers 2 > /dev/null || fail "the capped sharded build failed"
shards=$(json sharded/build_report.json "j['shards']['count']")
[ "$shards" -ge 4 ] || fail "expected at least 4 shards, got $shards"
[ "$(json sharded/build_report.json "j['counts']['node_layers_capped']")" -ge 1 ] || fail "no merge of the sharded build was capped"
consistent sharded
"$CITYATLAS" inspect -q sharded > inspect.txt 2>&1 || { tail -5 inspect.txt >&2; fail "inspect finds defects in the sharded folder"; }
"$CITYATLAS" build -q town/town.gml -o inproc --node-triangles 64 --d-min 200 --format both --shard-triangles 1500 \
  --workers 0 > /dev/null || fail "the capped in-process sharded build failed"
diff -r -q --exclude build_report.json --exclude .cityatlas-cache sharded inproc > diff.txt ||
  { head diff.txt >&2; fail "the capped shards built in this process give another folder"; }
echo "ok: $shards shards in 2 workers: $(json sharded/build_report.json "j['counts']['node_layers_capped']") layers capped, consistent, the in-process shards' folder"
