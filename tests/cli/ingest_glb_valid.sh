# The debug glb that `cityatlas ingest -o` writes passes the Khronos glTF
# validator with 0 errors, textures loaded from their relative URIs: for a
# synthetic town and for a real textured dataset (Berlin VCS export, when
# ../shared is present). Its triangle count equals the report's.
source "$(dirname "$0")/lib.sh" "$@"
ensure_gltf_validator

check_glb() {  # check_glb GLB REPORT
  set +e
  node "$GLTF_TOOLS/validate.mjs" "$1" > validate.txt 2>&1
  local rc=$?
  set -e
  cat validate.txt | head -5
  [ $rc -eq 0 ] || fail "$1: the glTF validator found errors"
  grep -q ": 0 errors" validate.txt || fail "$1: validator summary lacks '0 errors'"
  echo "ok: $1 validates"
}

"$CITYATLAS" synth --buildings 40 --texture-size 32 -q -o town > /dev/null
mkdir -p views
"$CITYATLAS" ingest town/town.gml -q -o views/town.glb --report town_report.json > /dev/null
check_glb views/town.glb
"$PY" - <<'PY' || fail "glb triangle count differs from the report"
import json, struct
data = open("views/town.glb", "rb").read()
length = struct.unpack_from("<I", data, 12)[0]
gltf = json.loads(data[20:20 + length])
tris = sum(gltf["accessors"][p["indices"]]["count"] // 3 if "indices" in p else gltf["accessors"][p["attributes"]["POSITION"]]["count"] // 3
           for m in gltf["meshes"] for p in m["primitives"])
want = json.load(open("town_report.json"))["triangles"]["total"]
assert tris == want, (tris, want)
uris = [i["uri"] for i in gltf.get("images", [])]
assert uris and all(not u.startswith("/") for u in uris), uris
print(f"ok: glb holds {tris} triangles = report; {len(uris)} images by relative URI")
PY

BERLIN="$SRC/../shared/data/citygml2_textured_berlin_vcs_export/export.gml"
if [ -f "$BERLIN" ]; then
  "$CITYATLAS" ingest "$BERLIN" -q -o berlin.glb > /dev/null
  check_glb berlin.glb
else
  echo "note: ../shared absent; real textured dataset not checked"
fi
