# features/bounds/<k>.bin (issue 18's groundwork, the spec's S2 and L1)
# against the synthetic town's own truth, read independently of the build:
# - every building's box equals its footprint's bounding box (footprints.shp
#   through GDAL's ogr2ogr) times [base, base + height] (truth.json), within
#   2 mm, in the local frame (source coordinates minus the tileset's
#   georeference.origin_source); base_z is its base;
# - the azimuth (binary16, read by Python's struct 'e') is the outward normal
#   of one of its longest footprint edges, within binary16's 0.125 degrees;
# - tileset.json addresses one bounds file per feature table, 32 bytes per
#   feature, and `inspect` accepts the folder; a bounds file one record short
#   and a record with min above max are defects that name the file.
source "$(dirname "$0")/lib.sh" "$@"
command -v ogr2ogr > /dev/null || fail "ogr2ogr (gdal-bin) is missing"

# Rotations 0, 90 and 3-4-5 degrees, every footprint shape and roof type;
# --feature-block 16 gives several tables.
"$CITYATLAS" synth --buildings 60 --seed 5 --texture-size 32 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 --feature-block 16 -q > /dev/null
ogr2ogr -f GeoJSON footprints.json town/footprints.shp
"$PY" - <<'PY' || fail "feature bounds differ from the truth (above)"
import json, math, struct, sys
truth = json.load(open("town/truth.json"))
# The local frame's origin in source coordinates, as the tileset states it.
ox, oy, oz = json.load(open("tiles/tileset.json"))["extras"]["cityatlas"]["georeference"]["origin_source"]
by_gml = {b["gml_id"]: b for b in truth["building_list"]}
shapes = {f["properties"]["gml_id"]: f for f in json.load(open("footprints.json"))["features"]}
fe = json.load(open("tiles/tileset.json"))["extras"]["cityatlas"]["features"]
bad = []
checked = 0
rotated = 0
for k, table in enumerate(fe["tables"]):
    records = json.load(open("tiles/" + table["uri"]))["features"]
    raw = open("tiles/" + table["bounds"]["uri"], "rb").read()
    assert len(raw) == table["bounds"]["bytes"] == 32 * len(records), (table, len(raw), len(records))
    for i, rec in enumerate(records):
        mn = struct.unpack_from("<3f", raw, 32 * i); mx = struct.unpack_from("<3f", raw, 32 * i + 12)
        base_z, = struct.unpack_from("<f", raw, 32 * i + 24)
        az, = struct.unpack_from("<e", raw, 32 * i + 28)
        flags, = struct.unpack_from("<H", raw, 32 * i + 30)
        b = by_gml[rec["gml_id"]]
        geom = shapes[rec["gml_id"]]["geometry"]
        polygons = geom["coordinates"] if geom["type"] == "MultiPolygon" else [geom["coordinates"]]
        xs = [p[0] - ox for poly in polygons for p in poly[0]]
        ys = [p[1] - oy for poly in polygons for p in poly[0]]
        base = b["base_height_m"] - oz
        want_min = (min(xs), min(ys), base); want_max = (max(xs), max(ys), base + b["ridge_height_m"])
        for a in range(3):
            if abs(mn[a] - want_min[a]) > 0.002 or abs(mx[a] - want_max[a]) > 0.002:
                bad.append(f"{rec['gml_id']}: box {mn} {mx}, truth {want_min} {want_max}")
                break
        if abs(base_z - base) > 0.002: bad.append(f"{rec['gml_id']}: base_z {base_z}, truth {base}")
        if flags != 1 | 2 | 4: bad.append(f"{rec['gml_id']}: flags {flags}, expected geometry + wall + textured (7)")
        # Outward normals of the longest edges, every ring (a courtyard's walls face into it).
        edges = []
        for poly in polygons:
            for r, ring in enumerate(poly):
                area = sum(ring[j][0] * ring[j + 1][1] - ring[j + 1][0] * ring[j][1] for j in range(len(ring) - 1))
                material_left = (area > 0) == (r == 0)  # exterior: its inside; a hole: outside it
                for j in range(len(ring) - 1):
                    dx = ring[j + 1][0] - ring[j][0]; dy = ring[j + 1][1] - ring[j][1]
                    nx, ny = (dy, -dx) if material_left else (-dy, dx)
                    edges.append((math.hypot(dx, dy), math.degrees(math.atan2(nx, ny)) % 360))
        longest = max(e[0] for e in edges)
        candidates = [e[1] for e in edges if e[0] > longest - 1e-6]
        if not any(min(abs(az - c), 360 - abs(az - c)) <= 0.125 for c in candidates):
            bad.append(f"{rec['gml_id']}: azimuth {az}, longest walls face {candidates}")
        rotated += any(abs(c % 90) > 1e-6 for c in candidates)
        checked += 1
print(f"checked {checked} buildings in {len(fe['tables'])} tables ({rotated} with a 3-4-5 rotation)")
for line in bad[:10]: print("FAIL:", line)
sys.exit(1 if bad or checked != truth["buildings"] or len(fe["tables"]) < 3 or rotated == 0 else 0)
PY
echo "ok: boxes, bases and azimuths equal the truth"

"$CITYATLAS" inspect tiles -q || fail "inspect rejects the folder"
# Defects: a bounds file one record short, and a record whose min is above its max.
cp -r tiles short
head -c -32 tiles/features/bounds/0.bin > short/features/bounds/0.bin
"$PY" - <<'PY'
import json
p = "short/tileset.json"; t = json.load(open(p))
t["extras"]["cityatlas"]["features"]["tables"][0]["bounds"]["bytes"] -= 32
json.dump(t, open(p, "w"))
PY
expect 1 "features/bounds/0.bin: 480 bytes, 16 features need 512" -- inspect short -q
cp -r tiles flipped
"$PY" - <<'PY'
import struct
p = "flipped/features/bounds/1.bin"; b = bytearray(open(p, "rb").read())
lo = struct.unpack_from("<f", b, 32 * 3)[0]; hi = struct.unpack_from("<f", b, 32 * 3 + 12)[0]
struct.pack_into("<f", b, 32 * 3, hi + 1); struct.pack_into("<f", b, 32 * 3 + 12, lo)
open(p, "wb").write(bytes(b))
PY
expect 1 "features/bounds/1.bin: record 3 has min .* above max" -- inspect flipped -q

# The client holds the bounds from the start, inside its budget: pinned bytes
# are the files' bytes; a budget below them is one clear line; a damaged
# file is an error in the report and the rest still load.
"$CITYATLAS" render tiles --frames 1 --size 64x48 -o r -q
total=$(json tiles/tileset.json "sum(t['bounds']['bytes'] for t in j['extras']['cityatlas']['features']['tables'])")
check_eq "render: pinned bytes = the bounds files" "$total" "$(json r/report.json "j['frames'][0]['pinned_bytes']")"
expect 1 "smaller than the feature bounds \\($total bytes\\)" -- render tiles --frames 1 --size 64x48 --budget $((total - 1)) -o r2 -q
"$CITYATLAS" render short --frames 1 --size 64x48 -o r3 -q
check_eq "render: a damaged bounds file is left out" "$((total - 512))" "$(json r3/report.json "j['frames'][0]['pinned_bytes']")"
check_eq "render: ... and reported" "True" "$(json r3/report.json "any('features/bounds/0.bin' in m for m in j['summary']['error_messages'])")"
