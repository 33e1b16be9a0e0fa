# The debug glb of a synthetic town (writeDebugGlb) passes the Khronos glTF
# validator with 0 errors, with every texture loaded from its relative URI; and
# the validator does fail on a glb with a missing texture, a wrong URI or a
# truncated file. Needs node >= 18 and npm (skipped, exit 77, without them);
# installs tests/tools/gltf/node_modules with `npm ci` on first use (network
# needed once; offline afterwards).
# The helper that writes the glb comes from the environment: SCENE_TO_GLB.
source "$(dirname "$0")/lib.sh" "$@"
[ -n "${SCENE_TO_GLB:-}" ] || fail "SCENE_TO_GLB is not set (path of the scene_to_glb helper)"
[ -x "$SCENE_TO_GLB" ] || fail "SCENE_TO_GLB=$SCENE_TO_GLB is not an executable"
ensure_gltf_validator
TOOLS="$GLTF_TOOLS"

"$CITYATLAS" synth --buildings 30 --texture-size 64 -q -o town > /dev/null
"$SCENE_TO_GLB" town town.glb
[ -s town.glb ] || fail "scene_to_glb wrote no town.glb"

rc=0; gltf_validate town.glb || rc=$?
[ $rc -eq 0 ] || { cat validate.txt >&2; fail "town.glb does not validate (exit $rc)"; }
grep -q "^town.glb: 0 errors" validate.txt || { cat validate.txt >&2; fail "unexpected summary"; }
echo "ok: $(head -1 validate.txt)"

# The validator really read every texture: one external resource per image.
images=$(glb_json town.glb "len(j.get('images', []))")
[ "$images" -gt 1 ] || fail "town.glb has $images images; expected the facade and paving textures"
check_eq "external resources loaded by the validator" "$images" \
  "$(sed -n 's/^  loaded \([0-9]*\) external resource.*/\1/p' validate.txt)"
check_eq "triangles in the glb" "$(glb_json town.glb "j['asset']['extras']['triangles']")" \
  "$(glb_json town.glb "sum(j['accessors'][p['attributes']['POSITION']]['count'] for p in j['meshes'][0]['primitives']) // 3")"

# --- The validator must be able to fail. ---

# 1. A texture file goes missing.
first=$(glb_json town.glb "j['images'][0]['uri']")
mv "$first" "$first.away"
expect_invalid town.glb "IO_ERROR" "a glb whose texture file is missing"
mv "$first.away" "$first"

# 2. One image URI points at a file that does not exist (same length, so the
#    GLB's chunk lengths stay right).
"$PY" - town.glb wrong_uri.glb "$first" <<'EOF'
import sys
src, dst, uri = sys.argv[1], sys.argv[2], sys.argv[3].encode()
b = open(src, 'rb').read()
assert b.count(uri) == 1, uri
bad = uri[:-5] + (b'Y' if uri[-5:-4] != b'Y' else b'Z') + uri[-4:]
open(dst, 'wb').write(b.replace(uri, bad))
EOF
cmp -s town.glb wrong_uri.glb && fail "wrong_uri.glb was not changed"
expect_invalid wrong_uri.glb "IO_ERROR" "a glb with an image URI to a missing file"

# 3. A truncated file.
head -c $(( $(stat -c %s town.glb) / 2 )) town.glb > truncated.glb
expect_invalid truncated.glb "^  error " "a truncated glb"

# Unreadable input is a usage/IO problem: exit 2.
set +e; node "$TOOLS/validate.mjs" no_such.glb > /dev/null 2>&1; rc=$?; set -e
check_eq "validator exit status for a missing file" 2 "$rc"

# The writer reports an unusable output path in one line and leaves nothing.
set +e; "$SCENE_TO_GLB" town no_such_dir/x.glb > out.txt 2> err.txt; rc=$?; set -e
check_eq "scene_to_glb exit status for a missing folder" 1 "$rc"
grep -q "no_such_dir/x.glb" err.txt || { cat err.txt >&2; fail "the error does not name the path"; }
[ ! -e no_such_dir ] || fail "a failed write created no_such_dir"
echo "ok: $(head -1 err.txt)"
