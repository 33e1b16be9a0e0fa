# Draco tile GLBs (tiles/glb_writer.h, encodeTileGlb) pass the Khronos glTF
# validator with 0 errors and 0 warnings, and a second, independent glTF reader
# (Draco's own, in draco_transcoder: tinygltf inside libdraco) decodes them to
# the counts their accessors state. The validator cannot decode Draco (it
# reports KHR_draco_mesh_compression as UNSUPPORTED_EXTENSION), hence the
# second reader; both must be able to fail, which the end checks.
#
# The GLBs come from the gtest TileGlb.WritesSampleFilesForTheValidator, which
# writes them into $CITYATLAS_GLB_OUT; the test binary comes from the
# environment: TEST_GLB_WRITER. Needs node >= 18 (skipped, exit 77, without
# it); the draco_transcoder part is skipped when the `draco` package is absent.
source "$(dirname "$0")/lib.sh" "$@"
[ -n "${TEST_GLB_WRITER:-}" ] || fail "TEST_GLB_WRITER is not set (path of the test_glb_writer gtest binary)"
[ -x "$TEST_GLB_WRITER" ] || fail "TEST_GLB_WRITER=$TEST_GLB_WRITER is not an executable"
ensure_gltf_validator
TOOLS="$GLTF_TOOLS"

PRIM="j['meshes'][0]['primitives'][0]"

mkdir glbs
CITYATLAS_GLB_OUT="$WORK/glbs" "$TEST_GLB_WRITER" --gtest_filter=TileGlb.WritesSampleFilesForTheValidator > gtest.txt 2>&1 ||
  { cat gtest.txt >&2; fail "the gtest that writes the sample GLBs failed"; }
expected="ecef_positions_atlas_uv.glb grid_32bit_indices.glb town_all_attributes.glb town_sequential_16bit.glb"
check_eq "sample GLBs written" "$expected" "$(cd glbs && ls *.glb | tr '\n' ' ' | sed 's/ $//')"

have_transcoder=1
command -v draco_transcoder > /dev/null || { have_transcoder=0; echo "note: draco_transcoder not installed (Debian: draco); skipping the second reader"; }

for f in glbs/*.glb; do
  rc=0; gltf_validate "$f" || rc=$?
  [ $rc -eq 0 ] || { cat validate.txt >&2; fail "$f does not validate (exit $rc)"; }
  grep -q "^$f: 0 errors, 0 warnings" validate.txt || { cat validate.txt >&2; fail "$f: errors or warnings"; }
  # The validator really saw the extension (and says it cannot check it).
  grep -q "UNSUPPORTED_EXTENSION.*KHR_draco_mesh_compression" validate.txt ||
    { cat validate.txt >&2; fail "$f: the validator did not see KHR_draco_mesh_compression"; }
  echo "ok: $(head -1 validate.txt)"

  if [ $have_transcoder -eq 1 ]; then
    # Draco's glTF reader decodes the primitive (through our JSON wiring) and
    # writes it again; its file states the counts it decoded. Edgebreaker may
    # split vertices, so triangles are compared, and vertices for edgebreaker
    # files only (the sequential one keeps the unsplit count).
    draco_transcoder -i "$f" -o "transcoded.glb" > transcoder.txt 2>&1 ||
      { cat transcoder.txt >&2; fail "$f: draco_transcoder cannot read it"; }
    check_eq "$f: indices read back by draco_transcoder" \
      "$(glb_json "$f" "j['accessors'][$PRIM['indices']]['count']")" \
      "$(glb_json transcoded.glb "j['accessors'][$PRIM['indices']]['count']")"
    check_eq "$f: attributes read back by draco_transcoder" \
      "$(glb_json "$f" "sorted($PRIM['attributes'])")" "$(glb_json transcoded.glb "sorted($PRIM['attributes'])")"
    case "$f" in
      *sequential*) ;;
      *) check_eq "$f: vertices read back by draco_transcoder" \
           "$(glb_json "$f" "j['accessors'][$PRIM['attributes']['POSITION']]['count']")" \
           "$(glb_json transcoded.glb "j['accessors'][$PRIM['attributes']['POSITION']]['count']")" ;;
    esac
  fi
done

# --- Both readers must be able to fail. ---
town=glbs/town_all_attributes.glb
# 1. A truncated file.
head -c $(( $(stat -c %s $town) / 2 )) $town > truncated.glb
expect_invalid truncated.glb "^  error " "a truncated glb"
# 2. TEXCOORD_1 without TEXCOORD_0 (what the writer once produced for atlas-only
#    meshes): renamed in place, same length, so the framing stays valid.
"$PY" -c "import sys; b=open(sys.argv[1],'rb').read(); open(sys.argv[2],'wb').write(b.replace(b'TEXCOORD_0', b'TEXCOORD_2'))" \
  $town gap.glb
expect_invalid gap.glb "MESH_PRIMITIVE_INDEXED_SEMANTIC_CONTINUITY" "a glb with TEXCOORD_1 but no TEXCOORD_0"
# 3. A damaged Draco blob passes the validator (it cannot decode Draco) but not
#    the second reader.
"$PY" - $town zeroed.glb <<'EOF'
import struct, sys
b = bytearray(open(sys.argv[1], 'rb').read())
blob = 20 + struct.unpack_from('<I', b, 12)[0] + 8
b[blob + 10:blob + 200] = bytes(190)
open(sys.argv[2], 'wb').write(b)
EOF
gltf_validate zeroed.glb || fail "the validator rejects a zeroed Draco blob now; update this script"
echo "ok: the validator alone accepts a zeroed Draco blob (it cannot decode Draco)"
if [ $have_transcoder -eq 1 ]; then
  set +e; draco_transcoder -i zeroed.glb -o x.glb > transcoder.txt 2>&1; rc=$?; set -e
  [ $rc -ne 0 ] || fail "draco_transcoder accepted a zeroed Draco blob"
  echo "ok: draco_transcoder rejects it: $(head -1 transcoder.txt)"
fi
