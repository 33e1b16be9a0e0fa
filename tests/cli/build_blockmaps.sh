# build --blockmaps (issue 20) through the command line; what the BlockMaps
# hold is tested in-process (tests/tiles/test_node_blockmaps.cpp):
#  1. off (the default) writes no BlockMap and no trace of the option in
#     tileset.json (default folders keep their bytes);
#  2. complement writes blockmap/<node>.bin for the root at least, says so in
#     tileset.json and build_report.json, and passes inspect (schema, every
#     BlockMap decoded and compared with its entry);
#  3. the option is part of the rebuild key, --blockmap-levels too (0: the
#     root's BlockMap alone);
#  4. a damaged BlockMap is a defect naming its file;
#  5. a bad value, --slurm and a sharded input are refused in one line, with
#     no folder left behind.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth -q --buildings 60 --seed 5 --texture-size 64 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o plain > /dev/null || fail "default build failed"
[ ! -e plain/blockmap ] || fail "a default build wrote BlockMaps"
check_eq "build.blockmaps, totals.bytes.blockmaps (default)" "None None" \
  "$(json plain/tileset.json "j['extras']['cityatlas']['build'].get('blockmaps')") $(json plain/tileset.json "j['extras']['cityatlas']['totals']['bytes'].get('blockmaps')")"

cp -r plain bm
"$CITYATLAS" build -q town/town.gml -o bm --blockmaps complement > /dev/null || fail "--blockmaps complement failed"
[ -s bm/blockmap/0.bin ] || fail "no root BlockMap (bm/blockmap/0.bin)"
check_eq "build.blockmaps" complement "$(json bm/tileset.json "j['extras']['cityatlas']['build'].get('blockmaps')")"
check_eq "the root's BlockMap entry names its file" blockmap/0.bin \
  "$(json bm/tileset.json "j['root']['extras']['cityatlas']['blockmap']['uri']")"
built=$(json bm/build_report.json "j['blockmaps']['built']")
[ "$built" -ge 1 ] || fail "build_report.json: blockmaps.built $built"
check_eq "BlockMap files = blockmaps.built" "$built" "$(ls bm/blockmap | wc -l)"
"$CITYATLAS" inspect bm > inspect.txt 2>&1 || { cat inspect.txt >&2; fail "inspect finds defects"; }
grep -q "blockmaps .* in $built files" inspect.txt || { cat inspect.txt >&2; fail "inspect does not report the BlockMaps"; }
echo "ok: $built BlockMap(s), the folder passes inspect"

cp -r bm root-only
"$CITYATLAS" build -q town/town.gml -o root-only --blockmaps complement --blockmap-levels 0 > /dev/null || fail "--blockmap-levels 0 failed"
check_eq "--blockmap-levels 0: levels tried, BlockMaps, files" "1 1 1" \
  "$(json root-only/build_report.json "str(len(j['blockmaps']['by_level'])) + ' ' + str(j['blockmaps']['built'])") $(ls root-only/blockmap | wc -l)"
check_eq "--blockmap-levels 0: deepest_level" 0 "$(json root-only/build_report.json "j['blockmaps']['deepest_level']")"

# 4. Damage: one byte of the root's BlockMap.
cp -r bm damaged
printf '\xff' | dd of=damaged/blockmap/0.bin bs=1 seek=100 conv=notrunc status=none
if "$CITYATLAS" inspect damaged > damaged.txt 2>&1; then fail "inspect passes a damaged BlockMap"; fi
grep -q "blockmap/0.bin" damaged.txt || { cat damaged.txt >&2; fail "the defect does not name blockmap/0.bin"; }
echo "ok: a damaged BlockMap is named: $(grep -m1 blockmap/0.bin damaged.txt)"

# 5. Refusals.
set +e
"$CITYATLAS" build -q town/town.gml -o bad --blockmaps replace > out.txt 2>&1; rc=$?
set -e
check_eq "--blockmaps replace exit code" 2 "$rc"
grep -q "expected off or complement" out.txt || { cat out.txt >&2; fail "no reason for the bad value"; }
set +e
"$CITYATLAS" build -q town/town.gml -o bad --blockmaps complement --blockmap-levels deep > out.txt 2>&1; rc=$?
set -e
check_eq "--blockmap-levels deep exit code" 2 "$rc"
grep -q "expected a level" out.txt || { cat out.txt >&2; fail "no reason for the bad level"; }
set +e
"$CITYATLAS" build -q town/town.gml -o bad --blockmaps complement --blockmap-sample corner > out.txt 2>&1; rc=$?
set -e
check_eq "--blockmap-sample corner exit code" 2 "$rc"
grep -q "expected centre or max" out.txt || { cat out.txt >&2; fail "no reason for the bad sampling"; }
set +e
"$CITYATLAS" build -q town/town.gml -o bad --blockmaps complement --slurm > out.txt 2>&1; rc=$?
set -e
check_eq "--blockmaps with --slurm exit code" 2 "$rc"
set +e
"$CITYATLAS" build -q town/town.gml -o bad --blockmaps complement --shard-triangles 1000 > out.txt 2>&1; rc=$?
set -e
check_eq "--blockmaps on a sharded input exit code" 1 "$rc"
check_eq "lines on stderr" 1 "$(wc -l < out.txt)"
grep -q "raise --shard-triangles" out.txt || { cat out.txt >&2; fail "no way out named"; }
[ ! -e bad ] && [ -z "$(ls -d bad.* 2>/dev/null)" ] || fail "a refused build left a folder: $(ls -d bad* 2>/dev/null)"
echo "ok: refusals: $(cat out.txt)"
