# --unique-charts (issue 19, M2) through the command line. The exact check
# (no texel claimed by two world-distinct triangles) is the atlas test
# test_unique_charts; this one checks that the option reaches every path:
#  1. tileset.json says "unique_charts": true only when asked (a default
#     folder keeps its bytes), and both folders pass inspect (schema included);
#  2. the option changes the atlas tree (the synthetic facades reuse texels
#     across walls, so regions are added);
#  3. a sharded build with the option gives the same folder with shards in
#     this process and in two workers, and its shards used the option;
#  4. the option is part of the rebuild key: rebuilding that folder without
#     it reuses no shard.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth -q --buildings 60 --seed 5 --texture-size 64 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o shared > /dev/null || fail "default build failed"
"$CITYATLAS" build -q town/town.gml -o unique --unique-charts > /dev/null || fail "--unique-charts build failed"
check_eq "build.unique_charts (default, option)" "None True" \
  "$(json shared/tileset.json "j['extras']['cityatlas']['build'].get('unique_charts')") $(json unique/tileset.json "j['extras']['cityatlas']['build'].get('unique_charts')")"
for d in shared unique; do
  "$CITYATLAS" inspect -q $d > inspect_$d.txt 2>&1 || { cat inspect_$d.txt >&2; fail "inspect finds defects in $d"; }
done
echo "ok: both folders pass inspect"
leaves() { json "$1/tileset.json" "j['extras']['cityatlas']['totals']['leaves']"; }
atlas_bytes() { json "$1/tileset.json" "j['extras']['cityatlas']['totals']['bytes']['atlases']"; }
[ "$(atlas_bytes unique)" -gt "$(atlas_bytes shared)" ] ||
  fail "unique charts should add atlas texels here: $(atlas_bytes unique) vs $(atlas_bytes shared) bytes"
echo "ok: atlases $(atlas_bytes shared) -> $(atlas_bytes unique) bytes, leaves $(leaves shared) -> $(leaves unique)"

"$CITYATLAS" build -q town/town.gml -o inproc --unique-charts --shard-triangles 1000 --workers 0 > /dev/null || fail "sharded, --workers 0 failed"
"$CITYATLAS" build -q town/town.gml -o workers --unique-charts --shard-triangles 1000 --workers 2 > /dev/null || fail "sharded, --workers 2 failed"
shards=$(json workers/build_report.json "j['shards']['count']")
[ "$shards" -ge 4 ] || fail "expected at least 4 shards, got $shards"
diff -r -q --exclude build_report.json --exclude .cityatlas-cache inproc workers > diff.txt || { head diff.txt >&2; fail "in-process and worker shards differ"; }
echo "ok: $shards shards, --workers 0 and 2 give the same folder"
"$CITYATLAS" build -q town/town.gml -o plain --shard-triangles 1000 --workers 0 > /dev/null || fail "sharded default build failed"
[ "$(atlas_bytes workers)" -gt "$(atlas_bytes plain)" ] || fail "the shards did not use --unique-charts"
echo "ok: the shards used the option ($(atlas_bytes plain) -> $(atlas_bytes workers) atlas bytes)"

"$CITYATLAS" build -q town/town.gml -o workers --shard-triangles 1000 --workers 2 > /dev/null || fail "rebuild without the option failed"
check_eq "shards reused after dropping --unique-charts" 0 "$(json workers/build_report.json "j['shards']['reused']")"
check_eq "build.unique_charts after the rebuild" None "$(json workers/tileset.json "j['extras']['cityatlas']['build'].get('unique_charts')")"
