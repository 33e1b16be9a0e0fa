# build --blockmaps (issue 20) through the command line; what the BlockMaps
# hold is tested in-process (tests/tiles/test_node_blockmaps.cpp):
#  1. off (the default) writes no BlockMap and no trace of the option in
#     tileset.json (default folders keep their bytes);
#  2. complement writes blockmap/<node>.bin for the root at least, says so in
#     tileset.json and build_report.json, and passes inspect (schema, every
#     BlockMap decoded and compared with its entry);
#  3. the option is part of the rebuild key, --blockmap-levels too (0: the
#     root's BlockMap alone);
#  3b. replace leaves the levels its BlockMaps cover completely without
#     geometry and atlases and is otherwise the complement folder; inspect
#     checks that the flag and the files agree;
#  4. a damaged BlockMap is a defect naming its file;
#  5. a bad value, replace with 3D Tiles output, --slurm and a sharded input
#     are refused in one line, with no folder left behind.
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

# 3b. replace: the levels the BlockMaps cover completely (from the root, no
# leaf) lose their geometry and atlases; everything else is byte for byte
# the complement folder's; inspect agrees, and catches the flag and the
# files disagreeing (a replaced node's file put back, the flag changed
# either way).
# (--d-min 30: a tree of a few levels; the default makes this town one leaf.)
"$CITYATLAS" build -q town/town.gml -o cmp --d-min 30 --blockmaps complement > /dev/null || fail "--blockmaps complement --d-min 30 failed"
"$CITYATLAS" build -q town/town.gml -o rep --d-min 30 --blockmaps replace > /dev/null || fail "--blockmaps replace failed"
check_eq "build.blockmaps (replace)" replace "$(json rep/tileset.json "j['extras']['cityatlas']['build'].get('blockmaps')")"
"$PY" - <<'PY' || fail "the replaced folder is not the complement folder less the replaced levels' files"
import json, os, filecmp
rep, bm = json.load(open("rep/tileset.json")), json.load(open("cmp/tileset.json"))
report = json.load(open("rep/build_report.json"))["blockmaps"]
def tiles(t):
    yield t
    for c in t.get("children", []): yield from tiles(c)
R, B = list(tiles(rep["root"])), list(tiles(bm["root"]))
assert len(R) == len(B)
# The rule, recounted from the complement folder: levels from the root whose every node is inner with a BlockMap.
levels = {}
for t in B:
    ca = t["extras"]["cityatlas"]
    levels.setdefault(ca["level"], []).append("blockmap" in ca and bool(t.get("children")))
L = 0
while L in levels and all(levels[L]): L += 1
assert L >= 1, f"the root is not covered ({levels.get(0)}): the town does not test replace"
assert report["replaced"]["levels"] == L, (report["replaced"], L)
omitted = nodes = 0
for r, b in zip(R, B):
    rc, bc = r["extras"]["cityatlas"], b["extras"]["cityatlas"]
    assert rc["blockmap"]["uri"] == bc["blockmap"]["uri"] if "blockmap" in bc else "blockmap" not in rc
    files = [l[k]["uri"] for l in bc["layers"].values() for k in ("geometry", "atlas") if l.get(k)]
    if bc["level"] < L:
        nodes += 1
        omitted += bc["bytes"]
        assert rc["layers"] == {} and "content" not in r and "contents" not in r and rc["bytes"] == 0, rc["id"]
        assert rc["features"]["dropped"] == [], rc["id"]
        for f in files: assert not os.path.exists("rep/" + f), f
    else:
        assert rc["layers"] == bc["layers"], rc["id"]
        for f in files: assert filecmp.cmp("rep/" + f, "cmp/" + f, shallow=False), f
for f in os.listdir("cmp/blockmap"):
    assert filecmp.cmp("rep/blockmap/" + f, "cmp/blockmap/" + f, shallow=False), f
assert (report["replaced"]["nodes"], report["replaced"]["bytes_omitted"]) == (nodes, omitted), (report["replaced"], nodes, omitted)
print(f"ok: replace: levels 0-{L - 1} ({nodes} nodes) are their BlockMaps alone, {omitted} bytes of geometry and atlases omitted; the rest as in complement")
PY
validate_json rep/build_report.json "$SRC/schemas/build_report.schema.json"
"$CITYATLAS" inspect rep > inspect.txt 2>&1 || { cat inspect.txt >&2; fail "inspect finds defects in the replaced folder"; }
# expect_defect FOLDER PATTERN WHAT: inspect exits 1 and names the defect.
expect_defect() {
  if "$CITYATLAS" inspect "$1" > defect.txt 2>&1; then fail "inspect passes $3"; fi
  grep -q -- "$2" defect.txt || { cat defect.txt >&2; fail "$3: inspect does not say '$2'"; }
  echo "ok: inspect catches $3: $(grep -m1 -- "$2" defect.txt)"
}
cp -r rep rep-file && cp cmp/geometry/opaque/0.glb rep-file/geometry/opaque/0.glb
expect_defect rep-file "geometry/opaque/0.glb is in the folder" "a replaced node's file put back"
cp -r rep rep-flag && sed -i 's/"blockmaps":"replace"/"blockmaps":"complement"/; s/"blockmaps": "replace"/"blockmaps": "complement"/' rep-flag/tileset.json
expect_defect rep-flag "build.blockmaps is complement, not replace" "the flag taken off a replaced folder"
cp -r cmp bm-flag && sed -i 's/"blockmaps":"complement"/"blockmaps":"replace"/; s/"blockmaps": "complement"/"blockmaps": "replace"/' bm-flag/tileset.json
expect_defect bm-flag "yet it keeps its geometry under build.blockmaps replace" "the flag put on a complement folder"

# 4. Damage: one byte of the root's BlockMap.
cp -r bm damaged
printf '\xff' | dd of=damaged/blockmap/0.bin bs=1 seek=100 conv=notrunc status=none
if "$CITYATLAS" inspect damaged > damaged.txt 2>&1; then fail "inspect passes a damaged BlockMap"; fi
grep -q "blockmap/0.bin" damaged.txt || { cat damaged.txt >&2; fail "the defect does not name blockmap/0.bin"; }
echo "ok: a damaged BlockMap is named: $(grep -m1 blockmap/0.bin damaged.txt)"

# 5. Refusals.
set +e
"$CITYATLAS" build -q town/town.gml -o bad --blockmaps all > out.txt 2>&1; rc=$?
set -e
check_eq "--blockmaps all exit code" 2 "$rc"
grep -q "expected off, complement or replace" out.txt || { cat out.txt >&2; fail "no reason for the bad value"; }
set +e
"$CITYATLAS" build -q town/town.gml -o bad --blockmaps replace --format both > out.txt 2>&1; rc=$?
set -e
check_eq "--blockmaps replace --format both exit code" 2 "$rc"
grep -q "a 3D Tiles client would draw nothing there" out.txt || { cat out.txt >&2; fail "no reason for replace with 3D Tiles"; }
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
