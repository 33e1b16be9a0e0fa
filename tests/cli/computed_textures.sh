# build --computed (issue 19) through the command line:
#  1. bad values are one-line usage errors (exit 2), nothing written;
#  2. a sharded build with sky_view, sun_hours and shadow passes inspect (the
#     schema, every BC4 file's header against its entry, sizes, statistics);
#  3. M1: its photo files (atlases, geometry, originals, features) are the same
#     bytes as the build without computed textures;
#  4. the computed values (sky view, sun hours, a shadow, the visibility of a
#     building) match an oracle (tests/tools/computed_oracle) that
#     casts again over the folder's decoded leaves (the whole scene, not a
#     shard and its occluders) at texels well inside one triangle;
#  5. T8: the same bytes with 1 and 2 threads, and in-process and in workers;
#  6. the horizon: at 1 km, larger than the town, values equal horizon=inf's;
#  7. the parameters are part of the rebuild key (no shard reused after a change).
source "$(dirname "$0")/lib.sh" "$@"
ORACLE="${COMPUTED_ORACLE:?}"

"$CITYATLAS" synth -q --buildings 60 --seed 5 --texture-size 64 -o town > /dev/null
COMMON=(--unique-charts --shard-triangles 1000)
SPECS=(--computed sky_view:directions=128,scale=2 --computed sun_hours:step=120,scale=2 --computed shadow:azimuth=135,elevation=30,scale=2
       --computed visibility:bldg_000012,scale=2)

# 1. Usage errors.
for bad in "sky_vieww" "sky_view:scale=3" "sky_view:directions=0" "shadow" "shadow:azimuth=1,elevation=-5" \
           "sun_hours:step=abc" "sky_view:foo=1" "shadow:time=2025-13-01T12:00" "visibility" "visibility:no_such_building"; do
  rc=0
  "$CITYATLAS" build -q town/town.gml -o never --computed "$bad" > out.txt 2> err.txt || rc=$?
  [ $rc -eq 2 ] || { cat err.txt >&2; fail "--computed $bad: exit $rc, expected 2"; }
  [ "$(wc -l < err.txt)" -eq 1 ] || { cat err.txt >&2; fail "--computed $bad: not one line"; }
  grep -q -- "--computed" err.txt || fail "--computed $bad: the message does not name the option: $(cat err.txt)"
  [ ! -e never ] || fail "--computed $bad left a folder"
done
echo "ok: 10 bad --computed values are one-line usage errors: $(head -c 120 err.txt)"

# 2. Built and inspected.
"$CITYATLAS" build -q town/town.gml -o plain "${COMMON[@]}" --workers 0 > /dev/null || fail "plain build failed"
"$CITYATLAS" build -q town/town.gml -o comp "${COMMON[@]}" "${SPECS[@]}" --workers 0 --threads 1 > /dev/null ||
  fail "build with computed textures failed"
shards=$(json comp/build_report.json "j['shards']['count']")
[ "$shards" -ge 4 ] || fail "expected at least 4 shards, got $shards"
"$CITYATLAS" inspect -q comp > inspect.txt 2>&1 || { cat inspect.txt >&2; fail "inspect finds defects"; }
check_eq "computed textures listed" "sky_view sun_hours shadow visibility" \
  "$(json comp/tileset.json "' '.join(c['name'] for c in j['extras']['cityatlas']['computed'])")"
files=$(find comp/computed -name '*.dds' | wc -l)
atlases=$(find comp/atlas -name '*.dds' | wc -l)
check_eq "computed files (4 per atlas)" $((4 * atlases)) "$files"

# 3. M1: photo files unchanged.
diff -r -q --exclude build_report.json --exclude tileset.json --exclude computed --exclude .cityatlas-cache plain comp > diff.txt ||
  { head diff.txt >&2; fail "the photo files differ with computed textures"; }
echo "ok: M1, $(find plain -type f | wc -l) photo files byte-identical with and without computed textures"

# 4. The oracle.
"$ORACLE" comp > oracle.json || fail "the oracle failed"
for k in 0 1 2 3; do
  name=$(json oracle.json "j[$k]['name']")
  texels=$(json oracle.json "j[$k]['texels']")
  [ "$texels" -ge 1000 ] || fail "$name: only $texels texels compared"
  check_eq "$name: texels in two triangles (unique charts)" 0 "$(json oracle.json "j[$k]['shared_texels']")"
  json oracle.json "j[$k]['fraction_over'] <= 0.002 and j[$k]['mean_abs'] <= 0.02" | grep -q True ||
    fail "$name: the oracle disagrees: $(json oracle.json "j[$k]")"
  echo "ok: $name matches the oracle on $texels texels: $(json oracle.json "'mean |d| %.4f, max %.3f, %d over tolerance' % (j[$k]['mean_abs'], j[$k]['max_abs'], j[$k]['over_tolerance'])")"
done

# 5. T8: threads and workers change nothing.
"$CITYATLAS" build -q town/town.gml -o comp2 "${COMMON[@]}" "${SPECS[@]}" --workers 0 --threads 2 > /dev/null || fail "2 threads failed"
"$CITYATLAS" build -q town/town.gml -o compw "${COMMON[@]}" "${SPECS[@]}" --workers 2 > /dev/null || fail "2 workers failed"
for d in comp2 compw; do
  diff -r -q --exclude build_report.json --exclude .cityatlas-cache comp $d > diff.txt || { head diff.txt >&2; fail "comp and $d differ"; }
done
echo "ok: T8, the same bytes with 1 and 2 threads and in 2 worker processes ($files computed files)"

# 6. The horizon: 1 km holds the whole town (diagonal below it), so inf changes no value.
"$CITYATLAS" build -q town/town.gml -o inf "${COMMON[@]}" --computed sky_view:directions=128,scale=2,horizon=inf --workers 0 > /dev/null ||
  fail "horizon=inf failed"
diff -r -q comp/computed/0 inf/computed/0 > diff.txt || { head diff.txt >&2; fail "horizon 1000 and inf differ on a small town"; }
echo "ok: sky_view with horizon 1000 m and inf: the same bytes"
"$CITYATLAS" build -q town/town.gml -o near "${COMMON[@]}" --computed sky_view:directions=128,scale=2,horizon=2 --workers 0 > /dev/null ||
  fail "horizon=2 failed"
mean_near=$(json near/tileset.json "j['extras']['cityatlas']['computed'][0]['statistics']['mean']")
mean_far=$(json comp/tileset.json "j['extras']['cityatlas']['computed'][0]['statistics']['mean']")
"$PY" -c "import sys; sys.exit(0 if $mean_near > $mean_far else 1)" ||
  fail "a 2 m horizon should see more sky than 1 km ($mean_near vs $mean_far)"
echo "ok: a 2 m horizon sees more sky (mean $mean_near against $mean_far)"

# 7. Rebuild keys.
"$CITYATLAS" build -q town/town.gml -o compw "${COMMON[@]}" "${SPECS[@]}" --workers 2 > up.txt || fail "rebuild failed"
grep -q "up to date" up.txt || fail "the same build is not up to date: $(cat up.txt)"
"$CITYATLAS" build -q town/town.gml -o compw "${COMMON[@]}" --computed sky_view:directions=64 --workers 2 > /dev/null ||
  fail "rebuild with other parameters failed"
check_eq "shards reused after changing --computed" 0 "$(json compw/build_report.json "j['shards']['reused']")"
check_eq "computed textures after the rebuild" "sky_view" \
  "$(json compw/tileset.json "' '.join(c['name'] for c in j['extras']['cityatlas']['computed'])")"

# 8. The client (M5): an inactive computed texture is never requested; the
#    shown one loads under the same budget, and at rest (--wait) no node is
#    drawn without it. A budget of a fifth of the folder keeps its invariant.
R=(--frames 30 --every 30 --size 320x180 -q)
"$CITYATLAS" render comp -o photo "${R[@]}" --wait > /dev/null || fail "render (photo) failed"
"$CITYATLAS" render comp -o sky "${R[@]}" --wait --computed sky_view > /dev/null || fail "render --computed sky_view failed"
total=$(json comp/tileset.json "sum(c['bytes'] for c in j['extras']['cityatlas']['computed'])")
budget=$(( $(du -sb comp/geometry comp/atlas comp/textures comp/computed | awk '{s+=$1} END {print s}') / 5 ))
"$CITYATLAS" render comp -o tight "${R[@]}" --computed visibility --computed-mode emphasis --budget "$budget" > /dev/null ||
  fail "render with a tight budget failed"
for d in photo sky tight; do validate_json $d/report.json "$SRC/schemas/render_report.schema.json"; done
check_eq "computed requests with none shown" 0 "$(json photo/report.json "sum(f['requests']['computed'] for f in j['frames'])")"
shown=$(json sky/report.json "sum(f['requests']['computed'] for f in j['frames'])")
[ "$shown" -gt 0 ] || fail "--computed sky_view requested no computed block"
check_eq "draws without their computed block at rest" 0 "$(json sky/report.json "max(f['computed_missing_draws'] for f in j['frames'])")"
check_eq "frames over the budget" 0 \
  "$(json tight/report.json "sum(1 for f in j['frames'] if f['resident_bytes'] + f['requested_bytes'] > f['budget_bytes'])")"
check_eq "the budget in the tight run" "$budget" "$(json tight/report.json "j['settings']['budget_bytes']")"
echo "ok: M5, $shown computed blocks loaded for sky_view (of $total bytes in all), none without --computed"
rc=0
"$CITYATLAS" render comp -o never "${R[@]}" --computed ambient > out.txt 2> err.txt || rc=$?
[ $rc -eq 2 ] && grep -q "only sky_view, sun_hours, shadow, visibility" err.txt || { cat err.txt >&2; fail "an unknown --computed: exit $rc"; }
echo "ok: an unknown computed texture is a usage error: $(cat err.txt)"
