# Sharded builds (cli/shards.h): plan, shards, merge.
#  1. a town cut into at least 4 shards builds the same folder, byte for byte
#     (build_report.json aside: timings), with shards in this process
#     (--workers 0) and in two worker processes (--workers 2);
#  2. the sharded folder passes inspect, and its leaves hold every triangle of
#     the scene exactly once, as the single-shard build's do (the sum of the
#     leaves' source triangles equals the scene's plus the critical splits);
#     the root's atlas, drawn by the merge from the shard roots' halves, has
#     their colours (halving keeps an image's mean; the root's packing adds
#     some empty room, far from half of it);
#  3. a shard worker killed mid-build: one error line naming the shard, exit 1,
#     no output folder and no working folder left;
#  4. `cityatlas shard` with an index outside the plan is a usage error.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth -q --buildings 60 --seed 5 --texture-size 64 -o town > /dev/null

"$CITYATLAS" build -q town/town.gml -o inproc --shard-triangles 1000 --workers 0 > /dev/null || fail "--workers 0 failed"
"$CITYATLAS" build -q town/town.gml -o workers --shard-triangles 1000 --workers 2 > /dev/null || fail "--workers 2 failed"
shards=$(json workers/build_report.json "j['shards']['count']")
[ "$shards" -ge 4 ] || fail "expected at least 4 shards, got $shards"
echo "ok: $shards shards"
diff -r -q --exclude build_report.json inproc workers > diff.txt || { head diff.txt >&2; fail "in-process and worker shards differ"; }
echo "ok: --workers 0 and --workers 2 give byte-identical folders ($(find workers -type f | wc -l) files)"

"$CITYATLAS" inspect -q workers > inspect.txt 2>&1 || { cat inspect.txt >&2; fail "inspect finds defects in the sharded folder"; }
echo "ok: inspect passes on the sharded folder"
"$PY" - workers <<'PYEOF' || fail "the merged root's atlas lost the shard roots' pixels"
import json, sys
import numpy as np
from PIL import Image
d = sys.argv[1]
root = json.load(open(f"{d}/tileset.json"))["root"]
def mean(uri):
    return float(np.asarray(Image.open(f"{d}/{uri}").convert("RGB"), dtype=float).mean())
def atlas(t):
    return t["extras"]["cityatlas"]["layers"]["opaque"]["atlas"]["uri"]
children = [mean(atlas(c)) for c in root["children"]]
m = mean(atlas(root))
print(f"ok: the root's atlas mean {m:.1f}, its children's {', '.join(f'{c:.1f}' for c in children)}")
sys.exit(0 if m >= 0.5 * sum(children) / len(children) else 1)
PYEOF
"$CITYATLAS" build -q town/town.gml -o single > /dev/null || fail "the single-shard build failed"
check_eq "single build's shard count" 1 "$(json single/build_report.json "j['shards']['count']")"
leaf_sources() {  # the leaves' source triangles, both layers, over the tile tree
  "$PY" - "$1/tileset.json" <<'PYEOF'
import json, sys
def walk(t):
    kids = t.get('children', [])
    if kids:
        return sum(walk(k) for k in kids)
    return sum(l['triangles_source'] for l in t['extras']['cityatlas']['layers'].values())
print(walk(json.load(open(sys.argv[1]))['root']))
PYEOF
}
scene_plus_splits() {
  json "$1/build_report.json" "j['counts']['triangles']"
}
s_single=$(leaf_sources single); s_sharded=$(leaf_sources workers)
check_eq "sharded leaves' source triangles" "$s_single" "$s_sharded"
[ "$s_single" -ge "$(scene_plus_splits single)" ] || fail "the leaves hold fewer triangles than the scene"
for d in single workers; do
  check_eq "$d: features in tileset.json" 60 "$(json $d/tileset.json "j['extras']['cityatlas']['features']['count']")"
done
# The originals each leaf needs, named by a shard with the city's texture
# numbers (a shard numbers only its own textures while it builds): the
# textures written as originals are the single build's, here all of them,
# and with --originals all too (the leaves' textures, not their needs).
written() { json "$1/tileset.json" "[i for i, t in enumerate(j['extras']['cityatlas']['textures']) if t['original'] == 'written']"; }
check_eq "textures written as originals, sharded" "$(written single)" "$(written workers)"
"$CITYATLAS" build -q town/town.gml -o single-all --originals all > /dev/null || fail "--originals all failed"
"$CITYATLAS" build -q town/town.gml -o sharded-all --originals all --shard-triangles 1000 > /dev/null ||
  fail "--originals all, sharded, failed"
check_eq "textures written as originals, sharded, --originals all" "$(written single-all)" "$(written sharded-all)"

# 3. A worker killed: the build fails cleanly.
"$CITYATLAS" synth -q --buildings 120 --seed 6 --texture-size 256 -o big > /dev/null
set +e
"$CITYATLAS" build -q big/town.gml -o killed --shard-triangles 1000 --workers 1 > kill.out 2> kill.err &
pid=$!
child=""
for _ in $(seq 1 400); do
  child=$(pgrep -P "$pid" -f " shard " | head -1)
  [ -n "$child" ] && break
  sleep 0.05
done
[ -n "$child" ] && kill -9 "$child"
wait "$pid"; rc=$?
set -e
[ -n "$child" ] || fail "no shard worker appeared"
check_eq "exit status after a killed worker" 1 "$rc"
grep -q "shard [0-9]* of [0-9]*: .*killed by signal 9" kill.err || { cat kill.err >&2; fail "the error does not name the killed shard"; }
[ "$(wc -l < kill.err)" -eq 1 ] || { cat kill.err >&2; fail "more than one error line"; }
echo "ok: $(cat kill.err)"
[ ! -e killed ] || fail "a killed build left an output folder"
[ -z "$(ls -a | grep '^killed\.')" ] || fail "a killed build left a working folder: $(ls -a | grep '^killed\.')"

# 4. Usage.
set +e
"$CITYATLAS" shard inproc --index 99 > usage.out 2>&1; rc=$?
set -e
[ "$rc" -ne 0 ] || fail "shard with a bad plan folder succeeded"
echo "ok: shard on a folder that is not a plan: exit $rc: $(head -1 usage.out)"
