# `cityatlas build --format both` on every dataset in ../shared/data (other
# parameters at their defaults), then `cityatlas inspect` on each folder:
# schema, every uri, every Draco mesh, every DDS header and size; and the 3D
# Tiles export against the official schemas and the glTF validator. The FZK-Haus examples mix a local engineering
# CRS with EPSG:25832 files, so they are built one file at a time (the mixed
# folder must fail with a clear message). Then London as a sharded build.
source "$(dirname "$0")/lib.sh" "$@"
DATA="$SRC/../shared/data"
if [ ! -d "$DATA" ]; then echo "SKIP: $DATA is absent (the team's shared data folder)"; exit 77; fi

ensure_gltf_validator
shared_inputs "$DATA"
n=0
for in in "${INPUTS[@]}"; do
  name="$(basename "$(dirname "$in")")/$(basename "$in")"; out="tiles_$n"; n=$((n + 1))
  set +e; "$CITYATLAS" build "$in" -o "$out" -q --format both > "$out.txt" 2> "$out.err"; rc=$?; set -e
  [ $rc -eq 0 ] || { cat "$out.err" >&2; fail "$name: build exit $rc"; }
  set +e; "$CITYATLAS" inspect "$out" > "$out.inspect" 2>&1; rc=$?; set -e
  [ $rc -eq 0 ] || { tail -20 "$out.inspect" >&2; fail "$name: inspect exit $rc"; }
  echo "ok: $name: $(head -1 "$out.txt" | sed 's/^Built [^:]*: //'); inspect: $(tail -1 "$out.inspect")"
  validate_export "$out" "$name (3D Tiles)"
done
expect 1 "no triangles" -- build "$DATA/citygml2_fzk_haus_official_examples/Building_LOD0-EPSG25832.gml" -o lod0 -q
[ ! -e lod0 ] || fail "the LOD0-only build left a folder behind"
expect 1 "local engineering CRS" -- build "$DATA/citygml2_fzk_haus_official_examples" -o mixed -q
[ ! -e mixed ] && [ ! -e mixed.partial ] || fail "the failed build left a folder behind"
# Real data through a sharded build: London (425 buildings) cut into shards of
# at most 2000 triangles, in this process and in two workers: one folder.
london="$DATA/citygml2_lod2_london_vcs"
"$CITYATLAS" build "$london" -o london_w0 -q --shard-triangles 2000 --workers 0 > /dev/null || fail "London, --workers 0"
"$CITYATLAS" build "$london" -o london_w2 -q --shard-triangles 2000 --workers 2 > /dev/null || fail "London, --workers 2"
shards=$(json london_w2/build_report.json "j['shards']['count']")
[ "$shards" -ge 4 ] || fail "London: expected at least 4 shards, got $shards"
diff -r -q --exclude build_report.json london_w0 london_w2 > /dev/null || fail "London: in-process and worker shards differ"
"$CITYATLAS" inspect -q london_w2 > /dev/null || fail "London sharded: inspect finds defects"
echo "ok: London in $shards shards: the same folder in-process and in two workers; inspect passes"
echo "ok: $n datasets built, inspected and their 3D Tiles exports validated"
