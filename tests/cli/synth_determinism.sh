# `synth --buildings 200 --lod 2 --seed 1 -o T` twice gives byte-identical
# folders holding the .gml, every texture it references, the shapefile set and truth.json.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth --buildings 200 --lod 2 --seed 1 -q -o T > run1.txt
"$CITYATLAS" synth --buildings 200 --lod 2 --seed 1 -q -o T2 > run2.txt
diff -r T T2 || fail "two runs with the same seed differ"
echo "ok: byte-identical outputs ($(find T -type f | wc -l) files)"

for f in town.gml footprints.shp footprints.shx footprints.dbf footprints.prj footprints.cpg truth.json; do
  [ -s "T/$f" ] || fail "missing or empty T/$f"
done
echo "ok: .gml, shapefile set (.shp .shx .dbf .prj .cpg) and truth.json present"

# Every imageURI resolves, relative to the .gml.
xmllint --xpath '//*[local-name()="imageURI"]/text()' T/town.gml | sort -u > hrefs.txt
[ -s hrefs.txt ] || fail "no imageURI in the CityGML"
while read -r href; do [ -f "T/$href" ] || fail "imageURI $href does not resolve"; done < hrefs.txt
echo "ok: all $(wc -l < hrefs.txt) distinct imageURIs resolve"
# ...and no texture is written that nothing references.
check_eq "textures on disk vs referenced" "$(wc -l < hrefs.txt)" "$(find T/textures -type f | wc -l)"

# A different seed gives a different town.
"$CITYATLAS" synth --buildings 200 --lod 2 --seed 2 -q -o T3 > /dev/null
cmp -s T/town.gml T3/town.gml && fail "seed 2 wrote the same CityGML as seed 1"
echo "ok: another seed, another town"
