# Coordinates honour --origin and --extreme: the written coordinates are the
# origin plus the same local town, in CityGML, shapefile and truth alike.
source "$(dirname "$0")/lib.sh" "$@"
args=(--buildings 24 --lod 2 --seed 9 --texture-size 32 -q)

"$CITYATLAS" synth "${args[@]}" -o base > /dev/null
"$CITYATLAS" synth "${args[@]}" --origin 321000,4567000,50 -o placed > /dev/null
"$CITYATLAS" synth "${args[@]}" --extreme -o extreme > /dev/null

# Envelope of the CityModel (first lowerCorner/upperCorner in the file) vs truth.
envelope() { xmllint --xpath "string((//*[local-name()='$2'])[1])" "$1/town.gml"; }
for T in base placed extreme; do
  "$PY" - "$T" "$(envelope $T lowerCorner)" "$(envelope $T upperCorner)" <<'PY' || fail "$T: envelope/origin mismatch"
import json, sys
t, lo, hi = sys.argv[1], [float(x) for x in sys.argv[2].split()], [float(x) for x in sys.argv[3].split()]
j = json.load(open(f"{t}/truth.json"))
o = j["settings"]["origin"]
assert lo == j["bbox_source"]["min"] and hi == j["bbox_source"]["max"], (lo, hi, j["bbox_source"])
# source = origin + local, exactly (coordinates are exact binary fractions)
assert [o[k] + j["bbox_local"]["min"][k] for k in range(3)] == lo
assert [o[k] + j["bbox_local"]["max"][k] for k in range(3)] == hi
# the town sits around its origin: the centre of its box is within 100 m of it
assert all(abs((lo[k] + hi[k]) / 2 - o[k]) < 100 for k in range(2)), (lo, hi, o)
print(f"ok: {t}: envelope {lo[:2]}..{hi[:2]} = origin {o} + local box")
PY
done
check_eq "placed origin" "[321000.0, 4567000.0, 50.0]" "$(json placed/truth.json "j['settings']['origin']")"

# --extreme: UTM 33S just south of the equator, northing ~9.9e6 m, in all three outputs.
grep -q 'srsName="urn:ogc:def:crs:EPSG::32733"' extreme/town.gml || fail "extreme town is not in EPSG:32733"
grep -q 'UTM_Zone_33S' extreme/footprints.prj || fail "extreme .prj is not UTM 33S"
ext=$(ogrinfo -ro -so -al extreme/footprints.shp | sed -n 's/^Extent: //p')
"$PY" -c "import re,sys; v=[float(x) for x in re.findall(r'-?[0-9.]+', sys.argv[1])]; assert 9.89e6 < v[1] < 9.91e6 and 8.2e5 < v[0] < 8.4e5, v; print('ok: extreme shapefile extent', v)" "$ext" \
  || fail "extreme shapefile extent not near (833000, 9900000)"

# The same local town wherever it is placed: only the origin differs.
"$PY" - <<'PY' || fail "placement changed the local geometry"
import json
def local(t):
    j = json.load(open(f"{t}/truth.json"))
    oz = j["settings"]["origin"][2]
    bl = [{k: (v - oz if k == "base_height_m" else v) for k, v in b.items()} for b in j["building_list"]]
    return j["bbox_local"], j["surfaces"], j["triangles"], bl
a, b, c = local("base"), local("placed"), local("extreme")
assert a == b == c
print("ok: base, placed and extreme towns have identical local geometry and truth")
PY

# Shapefile vertices are origin + local too: compare the first footprint's first vertex.
first_vertex() { ogrinfo -ro -q -al -fid 0 "$1/footprints.shp" | grep -o 'POLYGON ((.*' | sed 's/POLYGON ((//; s/,.*//'; }
"$PY" -c "
import sys
b=[float(x) for x in sys.argv[1].split()]; p=[float(x) for x in sys.argv[2].split()]
assert (p[0]-321000-(b[0]-690000), p[1]-4567000-(b[1]-5336000)) == (0.0, 0.0), (b, p)
print('ok: shapefile vertex moves with the origin:', b, '->', p)" "$(first_vertex base)" "$(first_vertex placed)" \
  || fail "shapefile vertex did not move with --origin"
