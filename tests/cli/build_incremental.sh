# Incremental rebuilds of a sharded build (cli/shards.h, reuseShards): two
# towns 3 km apart as two input files, cut into shards; then
#  1. one building of one town's CityGML moved by 1 m: the rebuild builds
#     only the shard holding it, reuses the others, and gives the folder a
#     full build of the new inputs gives, byte for byte;
#  2. one facade texture's pixels changed (same size): only the shard holding
#     its building and the original-texture block holding it are built
#     again, the rest reused, and again the folder equals a full build;
#  2b. the texture several shards share changed: each of them is built again;
#  3. --force rebuilds every shard and gives the same folder.
source "$(dirname "$0")/lib.sh" "$@"

synth() {  # synth DIR SEED EAST
  "$CITYATLAS" synth -q --buildings 30 --seed "$2" --texture-size 64 --origin "$3",5334000 -o "$1" --overwrite > /dev/null
}
synth a 5 690000
synth b 6 693000
# A small atlas makes small original-texture blocks (one atlas of texels: four
# 64 px facades), and --originals all puts every facade in one of them.
args=(--shard-triangles 300 --d-min 150 --atlas-size 128 --originals all -q)
"$CITYATLAS" build a/town.gml b/town.gml -o out "${args[@]}" > /dev/null || fail "the first build failed"
total=$(json out/build_report.json "j['shards']['count']")
[ "$total" -ge 4 ] || fail "expected at least 4 shards, got $total"
check_eq "first build: reused" 0 "$(json out/build_report.json "j['shards']['reused']")"

same_as_full() {  # same_as_full WHAT: out equals a full build of the current inputs
  rm -rf full
  "$CITYATLAS" build a/town.gml b/town.gml -o full "${args[@]}" > /dev/null || fail "$1: the full build failed"
  diff -r -q --exclude build_report.json --exclude .cityatlas-cache out full > diff.txt ||
    { head diff.txt >&2; fail "$1: the incremental build differs from the full build"; }
  check_eq "$1: shard keys as the full build's" "$(json full/build_report.json "j['shards']['keys']")" \
    "$(json out/build_report.json "j['shards']['keys']")"
  echo "ok: $1: the incremental folder equals the full build ($(find out -type f -not -path '*cache*' | wc -l) files)"
}

# 1. One building of town b moved 1 m east (its areas, and so the cuts, unchanged).
"$PY" - b/town.gml <<'PYEOF'
import re, sys
path = sys.argv[1]
text = open(path).read()
start = text.index('<bldg:Building gml:id="bldg_000030">')
end = text.index('</bldg:Building>', start)
def shift(m):
    v = [float(x) for x in m.group(2).split()]
    for i in range(0, len(v), 3): v[i] += 1.0
    return m.group(1) + " ".join(repr(x) for x in v) + m.group(3)
# synth writes gml:posList or gml:pos, by seed: both.
part, n = re.subn(r'(<gml:pos(?:List)?[^>]*>)([^<]*)(</gml:pos(?:List)?>)', shift, text[start:end])
if n == 0: sys.exit("no coordinates found in bldg_000030")
open(path, "w").write(text[:start] + part + text[end:])
PYEOF
"$CITYATLAS" build a/town.gml b/town.gml -o out "${args[@]}" > /dev/null || fail "the rebuild after b changed failed"
check_eq "b's building moved: shards built (the one holding it)" 1 "$(json out/build_report.json "j['shards']['built']")"
check_eq "b's building moved: shards reused" "$((total - 1))" "$(json out/build_report.json "j['shards']['reused']")"
blocks=$(json out/build_report.json "j['counts']['texture_blocks']")
[ "$blocks" -ge 4 ] || fail "expected several texture blocks, got $blocks"
echo "ok: b's building moved: texture blocks reused $(json out/build_report.json "j['shards']['texture_blocks_reused']") of $blocks"
same_as_full "b's building moved"

# 2. One of a's facade textures repainted (same size): only its shards are built.
repaint() {  # repaint FILE R G B: a 64 x 64 RGB PNG of one flat colour (same size, other pixels)
  "$PY" - "$@" <<'PYEOF'
import struct, sys, zlib
def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
raw = b"".join(b"\x00" + bytes([int(v) for v in sys.argv[2:5]]) * 64 for _ in range(64))
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 64, 64, 8, 2, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
open(sys.argv[1], "wb").write(png)
PYEOF
}
tex=$(ls a/textures/*.png | head -1)
repaint "$tex" 200 40 90
"$CITYATLAS" build a/town.gml b/town.gml -o out "${args[@]}" > /dev/null || fail "the rebuild after a texture changed failed"
# facade_000001.png is building 1's alone (synth: one facade texture per building).
check_eq "texture changed: shards built (the one holding its building)" 1 "$(json out/build_report.json "j['shards']['built']")"
check_eq "texture changed: texture blocks encoded (the one holding it)" 1 \
  "$(json out/build_report.json "j['shards']['texture_blocks_encoded']")"
check_eq "texture changed: texture blocks reused" "$(( $(json out/build_report.json "j['counts']['texture_blocks']") - 1 ))" \
  "$(json out/build_report.json "j['shards']['texture_blocks_reused']")"
same_as_full "texture changed"

# 2b. The paving texture repainted: synth's one global appearance puts it on
# roofs of many buildings, so several shards use it (each key lists it: a
# shard that missed it would keep the old pixels, and differ from the full build).
repaint a/textures/paving.png 30 160 60
"$CITYATLAS" build a/town.gml b/town.gml -o out "${args[@]}" > /dev/null || fail "the rebuild after paving changed failed"
built=$(json out/build_report.json "j['shards']['built']")
[ "$built" -ge 2 ] || fail "paving changed: expected the several shards using it to be built, got $built"
echo "ok: paving changed: $built of $total shards built"
same_as_full "paving changed"

# 3. --force: nothing reused, same folder.
"$CITYATLAS" build a/town.gml b/town.gml -o out "${args[@]}" --force > /dev/null || fail "--force failed"
check_eq "--force: shards reused" 0 "$(json out/build_report.json "j['shards']['reused']")"
check_eq "--force: texture blocks reused" 0 "$(json out/build_report.json "j['shards']['texture_blocks_reused']")"
same_as_full "--force"
