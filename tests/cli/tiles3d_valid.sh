# `build --format both|3dtiles`: the 3D Tiles 1.1 export validates against the
# official 3D Tiles 1.1 JSON Schemas (tests/data/schemas/3d-tiles-1.1, with
# python3-jsonschema; plus one content per tile, REPLACE, geometric errors
# non-increasing, content files present) and every GLB against the Khronos
# glTF validator with no error and no warning, for each --web-textures;
# a 3dtiles-only folder holds no native files and a rerun is up to date.
source "$(dirname "$0")/lib.sh" "$@"
ensure_gltf_validator
VALIDATE="$SRC/tests/tools/validate_3dtiles.py"
"$CITYATLAS" synth -q --buildings 60 --seed 4 --texture-size 64 -o town > /dev/null

validate_export() {  # validate_export FOLDER WHAT
  "$PY" "$VALIDATE" "$1/3dtiles/tileset.json" > schema.txt 2>&1 || { head -20 schema.txt >&2; fail "$2: tileset.json is not valid 3D Tiles 1.1"; }
  local glbs
  glbs=$(find "$1/3dtiles/tiles" -name '*.glb' | wc -l)
  [ "$glbs" -gt 0 ] || fail "$2: no GLB written"
  set +e
  find "$1/3dtiles/tiles" -name '*.glb' -print0 | xargs -0 node "$GLTF_TOOLS/validate.mjs" > validate.txt 2>&1
  local rc=$?
  set -e
  local bad
  bad=$(grep -c -v -E ': 0 errors, 0 warnings, [0-9]+ infos$' validate.txt || true)
  [ "$rc" -eq 0 ] && [ "$bad" -eq 0 ] || { grep -v ': 0 errors, 0 warnings' validate.txt | head -20 >&2; fail "$2: the glTF validator reports errors or warnings"; }
  echo "ok: $2: $(tail -1 schema.txt | sed 's/.*: valid/valid/'); $glbs GLBs with 0 errors, 0 warnings"
}

"$CITYATLAS" build -q town/town.gml -o both --d-min 30 --format both > build.txt
validate_export both "png (both)"
[ -f both/tileset.json ] || fail "--format both lost the native tileset.json"
"$CITYATLAS" inspect -q both > /dev/null || fail "the native half of --format both does not inspect clean"
tiles=$(json both/build_report.json "j['tiles3d']['tiles']")
nodes=$(json both/tileset.json "j['extras']['cityatlas']['totals']['nodes']")
check_eq "3D Tiles tiles = atlas-tree nodes" "$nodes" "$tiles"
[ "$(json both/build_report.json "j['tiles3d']['position_error_mm_max'] <= 2.0")" = True ] || fail "position error above 2 mm"

for format in jpeg webp; do
  "$CITYATLAS" build -q town/town.gml -o "$format" --d-min 30 --format 3dtiles --web-textures "$format" > /dev/null
  validate_export "$format" "$format (3dtiles)"
  for native in tileset.json geometry atlas textures features; do
    [ ! -e "$format/$native" ] || fail "--format 3dtiles left the native $native"
  done
done
"$CITYATLAS" build town/town.gml -o webp --d-min 30 --format 3dtiles --web-textures webp > rerun.txt
grep -q "up to date" rerun.txt || { cat rerun.txt >&2; fail "a 3dtiles-only folder is not found up to date"; }
"$CITYATLAS" build town/town.gml -o webp --d-min 30 --format 3dtiles --web-textures jpeg > rerun.txt
grep -q "^Built" rerun.txt || { cat rerun.txt >&2; fail "changing --web-textures did not rebuild"; }
echo "ok: 3dtiles-only folders hold no native files; reruns are up to date until --web-textures changes"
