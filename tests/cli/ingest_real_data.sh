# Every CityGML dataset in ../shared/data ingests without error (exit 0);
# building counts equal an independent XPath count; each report matches its
# JSON Schema; textured datasets keep their textures; the Berlin tile whose
# images are missing reports each one and falls back to colours.
source "$(dirname "$0")/lib.sh" "$@"
DATA="$SRC/../shared/data"
if [ ! -d "$DATA" ]; then echo "SKIP: $DATA is absent (the team's shared data folder)"; exit 77; fi

n=0
for f in "$DATA"/citygml*/*.gml; do
  name=$(basename "$(dirname "$f")")/$(basename "$f")
  rep="report_$n.json"; n=$((n + 1))
  set +e; "$CITYATLAS" ingest "$f" -q --report "$rep" > out.txt 2> err.txt; rc=$?; set -e
  [ $rc -eq 0 ] || { cat err.txt >&2; fail "$name: exit $rc"; }
  validate_json "$rep" "$SRC/schemas/ingest_report.schema.json"
  check_eq "$name buildings (xpath)" "$(xcount "$f" '//*[local-name()="Building"]')" "$(json "$rep" "j['inputs'][0]['buildings']")"
  check_eq "$name building parts (xpath)" "$(xcount "$f" '//*[local-name()="BuildingPart"]')" \
    "$(json "$rep" "j['objects_read'].get('BuildingPart', 0)")"
  case "$name" in
    citygml2_textured_berlin_vcs_export/*)
      check_eq "$name textures" "108" "$(json "$rep" "j['textures']['count']")" ;;
    citygml2_textured_plateau_tokyo_meiji_gallery/*)
      check_eq "$name textures" "1" "$(json "$rep" "j['textures']['count']")"
      # lat/lon file: local frame is metric (a ~100 m building, not 1e-3 degrees)
      "$PY" -c "import json,sys; b=json.load(open(sys.argv[1]))['bbox_local']; d=[b['max'][k]-b['min'][k] for k in range(2)]; assert all(20 < x < 1000 for x in d), d" "$rep" \
        || fail "$name: local frame is not in metres" ;;
    citygml2_textured_sig3d_appearance_example/*)
      [ "$(json "$rep" "j['triangles']['textured'] > 0")" == "True" ] || fail "$name: no textured triangles"
      check_eq "$name themes" "['Summer', 'Winter']" "$(json "$rep" "sorted(j['themes']['available'])")" ;;
    citygml1_lod2_berlin_tile_missing_textures/*)
      check_eq "$name missing images" "612" "$(json "$rep" "j['warnings']['texture_missing']['count']")"
      check_eq "$name textured triangles" "0" "$(json "$rep" "j['triangles']['textured']")" ;;
    citygml3_lod2_lyon_opera/*)
      check_eq "$name version" "3.0" "$(json "$rep" "j['inputs'][0]['citygml_version']")" ;;
  esac
  [ "$(json "$rep" "j['triangles']['total'] > 0 or j['features']['without_geometry'] > 0")" == "True" ] \
    || fail "$name: no triangles and no explanation"
done
echo "ok: $n datasets ingested"
