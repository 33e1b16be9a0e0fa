# The generator checked against its own truth.json by counting independently:
# XPath over the CityGML (xmllint), a Python recount of rings/areas, OGR over
# the shapefile (ogrinfo), OpenImageIO over the textures (iinfo), and the JSON
# Schema of truth.json (python3-jsonschema).
source "$(dirname "$0")/lib.sh" "$@"

for lod in 1 2; do
  T="town$lod"
  "$CITYATLAS" synth --buildings 90 --lod $lod --seed 5 --texture-size 64 -q -o "$T" > /dev/null
  G="$T/town.gml"; J="$T/truth.json"
  echo "--- LOD$lod"
  validate_json "$J" "$SRC/schemas/truth.schema.json"
  echo "ok: truth.json matches its JSON Schema"

  check_eq "bldg:Building (xpath)" "$(json "$J" "j['buildings']")" "$(xcount "$G" '//*[local-name()="Building"]')"
  check_eq "gml:Polygon (xpath)" "$(json "$J" "j['polygons']")" "$(xcount "$G" '//*[local-name()="Polygon"]')"
  check_eq "gml:interior (xpath)" "$(json "$J" "j['interior_rings']")" "$(xcount "$G" '//*[local-name()="interior"]')"
  if [ $lod -eq 2 ]; then
    check_eq "WallSurface" "$(json "$J" "j['surfaces']['wall']['polygons']")" "$(xcount "$G" '//*[local-name()="WallSurface"]')"
    check_eq "RoofSurface" "$(json "$J" "j['surfaces']['roof']['polygons']")" "$(xcount "$G" '//*[local-name()="RoofSurface"]')"
    check_eq "GroundSurface" "$(json "$J" "j['surfaces']['ground']['polygons']")" "$(xcount "$G" '//*[local-name()="GroundSurface"]')"
    check_eq "lod2Solid xlinks" "$(json "$J" "j['polygons']")" \
      "$(xcount "$G" '//*[local-name()="lod2Solid"]//*[local-name()="surfaceMember"][@*[local-name()="href"]]')"
  else
    check_eq "lod1Solid" "$(json "$J" "j['buildings']")" "$(xcount "$G" '//*[local-name()="lod1Solid"]')"
    check_eq "no thematic surfaces in LOD1" "0" "$(xcount "$G" '//*[local-name()="WallSurface"]')"
  fi
  "$PY" "$SRC/tests/cli/recount_citygml.py" "$T" || fail "independent recount of $G disagrees with truth.json"

  # Textures: what the file references, what is on disk, channels and sizes.
  check_eq "distinct imageURIs" "$(json "$J" "j['textures']['count']")" \
    "$(xmllint --xpath '//*[local-name()="imageURI"]/text()' "$G" | sort -u | wc -l)"
  iinfo "$T"/textures/*.png > iinfo.txt
  check_eq "RGBA textures (iinfo)" "$(json "$J" "j['textures']['rgba']")" "$(grep -c '4 channel' iinfo.txt)"
  check_eq "RGB textures (iinfo)" "$(json "$J" "j['textures']['rgb']")" "$(grep -c '3 channel' iinfo.txt)"
  check_eq "textures of 64x64 (iinfo)" "$(json "$J" "j['textures']['count']")" "$(grep -cE ' 64 x +64,' iinfo.txt)"

  # Shapefile through OGR.
  S="$T/footprints.shp"
  check_eq "shapefile features (ogrinfo)" "$(json "$J" "j['buildings']")" \
    "$(ogrinfo -ro -so -al "$S" | sed -n 's/^Feature Count: //p')"
  ogrinfo -ro -q -al "$S" | sed -n 's/^ *gml_id (String) = //p' | sort > shp_ids.txt
  json "$J" "'\n'.join(sorted(b['gml_id'] for b in j['building_list']))" > truth_ids.txt
  diff -q shp_ids.txt truth_ids.txt > /dev/null || fail "shapefile gml_ids differ from truth"
  echo "ok: shapefile ids = truth ids"
  area=$(ogrinfo -ro -q -sql "SELECT SUM(OGR_GEOM_AREA) AS a FROM footprints" "$S" | sed -n 's/^ *a (Real) = //p')
  "$PY" -c "import json,sys; want=sum(b['footprint_area_m2'] for b in json.load(open(sys.argv[1]))['building_list']); got=float(sys.argv[2]); assert abs(got-want) <= 1e-9*want, (got, want); print('ok: footprint area (OGR) =', got)" "$J" "$area" \
    || fail "footprint areas from OGR differ from truth"
  grep -q 'PROJCS\[' "$T/footprints.prj" || fail ".prj holds no projected CRS"
  echo "ok: .prj present with a projected CRS"
done
