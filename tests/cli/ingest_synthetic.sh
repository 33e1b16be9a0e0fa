# `cityatlas ingest` of synthetic towns (LOD2, LOD1, extreme placement)
# reproduces truth.json through the CLI and its report: buildings, textures,
# triangles and area per surface kind (1e-9 relative), with no warnings.
source "$(dirname "$0")/lib.sh" "$@"
for variant in "--lod 2" "--lod 1" "--lod 2 --extreme"; do
  rm -rf town
  "$CITYATLAS" synth --buildings 60 $variant --seed 4 --texture-size 16 -q -o town > /dev/null
  "$CITYATLAS" ingest town/town.gml -q --report report.json > /dev/null
  "$PY" - <<'PY' || fail "ingest of synth $variant disagrees with truth.json"
import json
t = json.load(open("town/truth.json")); r = json.load(open("report.json"))
assert r["inputs"][0]["buildings"] == t["buildings"], (r["inputs"][0]["buildings"], t["buildings"])
assert r["features"]["total"] == t["buildings"]
assert r["textures"]["count"] == t["textures"]["count"] and r["textures"]["failed"] == 0
assert r["triangles"]["total"] == t["triangles"]
for kind, want in t["surfaces"].items():
    got = r["triangles"]["by_semantic"][kind]
    assert got["triangles"] == want["triangles"], (kind, got, want)
    rel = abs(got["area_m2"] - want["area_m2"]) / want["area_m2"]
    assert rel <= 1e-9, (kind, rel)
assert r["warnings_total"] == 0, r["warnings"]
assert r["polygons"]["textured"] == t["textured_polygons"], (r["polygons"], t["textured_polygons"])
print("ok:", t["settings"]["crs"], "LOD", t["settings"]["lod"], "-", t["triangles"], "triangles match truth")
PY
done

# The synth folder itself holds every building twice (town.gml and
# footprints.shp): reading the folder warns once, naming both files; reading
# town.gml alone does not.
"$CITYATLAS" synth --buildings 12 --seed 4 --texture-size 16 -q -o twice > /dev/null
"$CITYATLAS" ingest -q twice --report twice.json > twice.txt || fail "ingest of a synth folder failed"
check_eq "inputs_overlap warnings for a synth folder" 1 "$(json twice.json "j['warnings']['inputs_overlap']['count']")"
detail=$(json twice.json "j['warnings']['inputs_overlap']['examples'][0]['file'] + ' | ' + j['warnings']['inputs_overlap']['examples'][0]['detail']")
case "$detail" in *town.gml*footprints.shp*|*footprints.shp*town.gml*) echo "ok: names both: $detail" ;;
  *) fail "the overlap warning does not name both files: $detail" ;; esac
grep -q "inputs_overlap" twice.txt || fail "the overlap warning is not printed"
"$CITYATLAS" ingest -q twice/town.gml --report once.json > /dev/null
check_eq "warnings for town.gml alone" 0 "$(json once.json "j['warnings_total']")"
