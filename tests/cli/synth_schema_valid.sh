# The CityGML that synth writes validates against the official CityGML 2.0
# XML Schemas, offline (tests/data/schemas/citygml2 with its XML catalog).
source "$(dirname "$0")/lib.sh" "$@"
S="$SRC/tests/data/schemas/citygml2"
[ -f "$S/catalog.xml" ] || fail "schemas missing: $S"
export XML_CATALOG_FILES="$S/catalog.xml"

validate() {
  local out rc
  set +e
  out=$(xmllint --nonet --noout --schema "$S/schemas.opengis.net/citygml/profiles/base/2.0/CityGML.xsd" "$1" 2>&1)
  rc=$?
  set -e
  # One harmless warning about the circular smil20 import is always printed.
  [ $rc -eq 0 ] || { echo "$out" | grep -v smil20-language | head -20 >&2; fail "$1 does not validate (xmllint rc $rc)"; }
  echo "ok: $1 validates"
}

"$CITYATLAS" synth --buildings 60 --lod 2 --seed 3 --texture-size 32 -q -o lod2 > /dev/null
"$CITYATLAS" synth --buildings 60 --lod 1 --seed 3 --texture-size 32 -q -o lod1 > /dev/null
"$CITYATLAS" synth --buildings 30 --lod 2 --extreme --texture-size 32 -q -o extreme > /dev/null
validate lod2/town.gml
validate lod1/town.gml
validate extreme/town.gml

# The validator must be able to fail: a building with an element out of schema order.
sed '0,/<bldg:roofType>/s//<bldg:noSuchElement\/><bldg:roofType>/' lod2/town.gml > broken.gml
set +e
xmllint --nonet --noout --schema "$S/schemas.opengis.net/citygml/profiles/base/2.0/CityGML.xsd" broken.gml >/dev/null 2>&1
rc=$?
set -e
[ $rc -ne 0 ] || fail "a deliberately invalid file validated: the check is not working"
echo "ok: a deliberately invalid file is rejected (rc $rc)"
