# `cityatlas build` end to end on a synthetic town, and `cityatlas inspect`:
# the folder matches its schemas; every GLB passes the Khronos glTF validator;
# a rerun with the same inputs does nothing, a changed texture or parameter
# rebuilds; bad input leaves no folder behind; the extreme-coordinates town
# keeps its position error within 2 mm; inspect passes on the build and fails,
# naming the file, on a deleted block, a truncated GLB and a corrupted DDS header.
source "$(dirname "$0")/lib.sh" "$@"
ensure_gltf_validator

"$CITYATLAS" synth --buildings 30 --seed 3 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 150 -q > build.txt
cat build.txt
validate_json tiles/build_report.json "$SRC/schemas/build_report.schema.json"
"$PY" -c "import json,jsonschema,sys; jsonschema.validate(json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), cls=jsonschema.Draft7Validator)" \
  tiles/tileset.json "$SRC/schemas/tileset.schema.json" || fail "tileset.json does not match its schema"
echo "ok: tileset.json and build_report.json match their schemas"
[ ! -e tiles.partial ] || fail "the working folder tiles.partial was left behind"
[ ! -e tiles/.atlas-png ] || fail "the atlas PNG working folder was left in the output"

# Counts against the town's own truth and the tree.
check_eq "features" "$(json town/truth.json "j['buildings']")" "$(json tiles/build_report.json "j['counts']['features']")"
check_eq "root draws or lists every feature" "30" \
  "$(json tiles/build_report.json "j['root']['features'] + len(j['root']['features_dropped'])")"
check_eq "geometry files on disk" "$(find tiles/geometry -name '*.glb' | wc -l)" "$(json tiles/build_report.json "j['counts']['geometry_files']")"
check_eq "atlas files on disk" "$(find tiles/atlas -name '*.dds' | wc -l)" "$(json tiles/build_report.json "j['counts']['atlas_files']")"
[ "$(json tiles/build_report.json "j['errors']['position_mm_max'] <= 2.0")" == "True" ] || fail "position error above 2 mm"

# Someone else's checks: every GLB through the Khronos validator.
set +e; node "$GLTF_TOOLS/validate.mjs" $(find tiles/geometry -name '*.glb' | sort) > validate.txt 2>&1; rc=$?; set -e
[ $rc -eq 0 ] || { grep -v ' 0 errors' validate.txt | head -20 >&2; fail "the glTF validator found errors"; }
check_eq "GLBs with 0 errors" "$(find tiles/geometry -name '*.glb' | wc -l)" "$(grep -c ': 0 errors' validate.txt)"
# ... and every atlas through OpenImageIO's DDS reader (full mip chain).
# Globs, not `ls | head`: head closing the pipe early kills ls with SIGPIPE, which pipefail reports.
atlases=(tiles/atlas/*/*.dds)
for f in "${atlases[@]:0:20}"; do
  info=$(iinfo -v "$f")  # captured: `grep -q` would close the pipe early (SIGPIPE under pipefail)
  grep -Eq 'compression: "DXT[15]"' <<<"$info" || fail "$f: OpenImageIO does not read it as DXT1/DXT5"
done
echo "ok: OpenImageIO reads the DDS atlases"

# Rerun: nothing to do, nothing touched.
stamp=$(stat -c %y tiles/tileset.json)
"$CITYATLAS" build town/town.gml -o tiles --d-min 150 -q > rerun.txt
grep -q "up to date" rerun.txt || { cat rerun.txt; fail "rerun did not say it was up to date"; }
check_eq "tileset.json untouched by the rerun" "$stamp" "$(stat -c %y tiles/tileset.json)"
# A changed parameter rebuilds; so does a changed texture (same size, new bytes).
"$CITYATLAS" build town/town.gml -o tiles --d-min 150 --position-bits 16 -q > rebuild.txt
grep -q "up to date" rebuild.txt && fail "a changed parameter was not rebuilt"
check_eq "position bits recorded" "16" "$(json tiles/tileset.json "j['extras']['cityatlas']['build']['position_bits']")"
textures=(town/textures/*.png); tex=${textures[0]}
oiiotool "$tex" --invert -o "$tex"
"$CITYATLAS" build town/town.gml -o tiles --d-min 150 --position-bits 16 > rebuild2.txt 2> rebuild2.err
grep -q "up to date" rebuild2.txt && fail "a changed texture was not rebuilt"
grep -q "texture .* changed" rebuild2.err || { cat rebuild2.err; fail "the rebuild does not say which texture changed"; }
echo "ok: parameters and texture contents invalidate the build"

# Atomic output: a failing build leaves neither a folder nor a working folder.
printf 'not xml' > broken.gml
expect 1 "broken.gml" -- build broken.gml -o never -q
[ ! -e never ] && [ ! -e never.partial ] || fail "a failed build left a folder behind"
expect 1 "not a cityatlas build" -- build town/town.gml -o town -q
expect 2 "--bc-quality" -- build town/town.gml -o x --bc-quality medium

# inspect: passes on the build, fails naming the damaged file.
"$CITYATLAS" inspect tiles > inspect.txt || { cat inspect.txt; fail "inspect fails on a fresh build"; }
grep -q "OK" inspect.txt || fail "inspect did not say OK"
damage() {  # damage NAME COMMAND...: copy the folder, damage it, inspect must fail naming the file
  rm -rf "bad_$1"; cp -r tiles "bad_$1"; (cd "bad_$1" && eval "$2")
  set +e; "$CITYATLAS" inspect "bad_$1" > /dev/null 2> "bad_$1.err"; local rc=$?; set -e
  [ $rc -eq 1 ] || fail "inspect on $1: exit $rc, expected 1"
  grep -q -- "$3" "bad_$1.err" || { cat "bad_$1.err" >&2; fail "inspect on $1 does not name $3"; }
  echo "ok: inspect finds $1: $(grep -m1 -- "$3" "bad_$1.err")"
}
first_of() { echo "${1#tiles/}"; }  # first_of GLOB...: the first match, relative to tiles/
block=$(first_of tiles/textures/*.bin)
glb=$(first_of tiles/geometry/opaque/*.glb)
dds=$(first_of tiles/atlas/opaque/*.dds)
damage "deleted block" "rm $block" "$block"
damage "truncated glb" "truncate -s \$((\$(stat -c %s $glb) / 2)) $glb" "$glb"
damage "corrupted DDS header" "printf 'XXXX' | dd of=$dds bs=1 seek=84 conv=notrunc status=none" "$dds"
expect 1 "tileset.json" -- inspect town

# The extreme town (UTM 33S, northing 9.9e6 m): millimetres at default bits.
"$CITYATLAS" synth --buildings 12 --extreme -o xtown -q > /dev/null
"$CITYATLAS" build xtown/town.gml -o xtiles --d-min 150 -q > /dev/null
[ "$(json xtiles/build_report.json "j['errors']['position_mm_max'] <= 2.0")" == "True" ] || fail "extreme town: position error above 2 mm"
[ "$(json xtiles/tileset.json "len(j['root']['transform']) == 16")" == "True" ] || fail "extreme town: no root transform"
# The transform takes the local origin to the ECEF of the grid origin (PROJ's cs2cs as the reference).
read -r e n h <<< "$(json xtiles/tileset.json "' '.join(str(v) for v in j['extras']['cityatlas']['georeference']['origin_source'])")"
crs=$(json xtiles/tileset.json "j['extras']['cityatlas']['georeference']['source_crs']")
read -r X Y Z <<< "$(echo "$e $n $h" | cs2cs -f %.4f "$crs" EPSG:4978 | awk '{print $1, $2, $3}')"
"$PY" -c "import json,sys; t=json.load(open(sys.argv[1]))['root']['transform']; d=[abs(t[12]-float(sys.argv[2])), abs(t[13]-float(sys.argv[3])), abs(t[14]-float(sys.argv[4]))]; assert max(d) < 0.01, d" \
  xtiles/tileset.json "$X" "$Y" "$Z" || fail "extreme town: root transform does not put the origin where cs2cs does"
"$CITYATLAS" inspect xtiles > /dev/null || fail "inspect fails on the extreme town"
echo "ok: extreme town within 2 mm, placed as cs2cs places it"

# CPU per stage: the top-level stages' cpu_seconds add up to the CPU time the
# operating system charged the build process (Python's getrusage of its waited
# child as the oracle), less what runs outside any stage (start-up, the input
# digests, writing the report); no stage of 0.1 s or more keeps more cores busy
# than there are.
"$PY" - "$CITYATLAS" <<'PY' || fail "stage CPU times do not match the process's"
import json, os, resource, subprocess, sys
subprocess.run([sys.argv[1], "build", "town/town.gml", "-o", "cpu_tiles", "-q", "--format", "both", "--d-min", "80"],
               check=True, stdout=subprocess.DEVNULL)
u = resource.getrusage(resource.RUSAGE_CHILDREN)
charged = u.ru_utime + u.ru_stime
stages = json.load(open("cpu_tiles/build_report.json"))["stages"]
top = [s for s in stages if ":" not in s["name"]]
assert [s["name"] for s in top] == ["read", "atlas", "tiles", "3dtiles"], [s["name"] for s in top]
total = sum(s["cpu_seconds"] for s in top)
assert total <= charged + 0.02 and total >= 0.8 * charged - 0.1, (total, charged)
for s in stages:
    # getrusage counts in ticks and TBB's workers spin on after a step: a sub-0.1 s
    # step's ratio is noise (measured: 2.84 "cores" over 0.4 ms on 2 cores).
    if s["seconds"] >= 0.1: assert s["cores_busy"] <= os.cpu_count() * 1.05 + 0.05, s
    assert abs(s["cores_busy"] - s["cpu_seconds"] / max(s["seconds"], 1e-9)) < 0.01 or s["seconds"] < 1e-3, s
print(f"ok: stages' CPU {total:.2f} s of the {charged:.2f} s charged to the build; most cores busy "
      f"{max(s['cores_busy'] for s in top):.2f} of {os.cpu_count()}")
PY
