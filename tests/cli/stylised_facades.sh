# build --facades stylised (issue 19 item 4, papers/000 §5.2.2) end to end;
# the analysis itself is tested against the synthetic facades' truth in
# tests/ingest/test_stylised_facades.cpp.
#  1. on a synthetic town, every facade texture (only walls use them) is
#     stylised and the paving (roofs) is kept; the folder passes inspect;
#  2. each stored facade original (the folder's DDS, decoded by Pillow) is
#     two colours (within BC1's rounding) on >= 98 % of its pixels, with at
#     least one window; the same check fails on the photo build's (so it can
#     fail), and the paving is byte-identical in both;
#  3. the same build again (to another folder) gives the same folder; into
#     the same folder it is up to date, and an edited photo rebuilds it;
#  4. Berlin's oblique aerial facade crops (../shared/data) are counted as not
#     upright and get their colour only;
#  5. --facades with an unknown value is refused in one line.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth -q --buildings 12 --seed 3 --texture-size 128 -o town > /dev/null
"$CITYATLAS" build town/town.gml -o photo -q > /dev/null || fail "photo build failed"
"$CITYATLAS" build town/town.gml -o styl --facades stylised > build.txt 2>&1 || { cat build.txt >&2; fail "build failed"; }
grep -q "stylised facades: 12 textures, 0 of them one colour (0 not upright on their walls); 1 kept as they are" build.txt ||
  { cat build.txt >&2; fail "expected the 12 facades stylised and the paving kept"; }
echo "ok: 12 facades stylised, the paving kept"
"$CITYATLAS" inspect -q styl > inspect.txt 2>&1 || { cat inspect.txt >&2; fail "inspect finds defects"; }

"$PY" - photo styl <<'PY'
import io, json, sys
from PIL import Image
def originals(folder):
    t = json.load(open(f"{folder}/tileset.json"))["extras"]["cityatlas"]
    out = []
    for e in t["textures"]:
        block = open(f"{folder}/{t['texture_blocks'][e['block']]['uri']}", "rb").read()
        out.append(block[e["offset"]:e["offset"] + e["bytes"]])
    return out
def two_colour_share(dds):
    img = Image.open(io.BytesIO(dds)).convert("RGB")
    counts = sorted(((n, c) for n, c in img.getcolors(1 << 20)), reverse=True)
    close = lambda a, b: max(abs(a[k] - b[k]) for k in range(3)) <= 6  # BC1's rounding of a flat colour
    top = [counts[0][1]]  # the most frequent colour, and the most frequent one apart from it
    top += [c for _, c in counts if not close(c, top[0])][:1]
    near = sum(n for n, c in counts if any(close(c, t) for t in top))
    return near / (img.width * img.height), len(counts)
photo, styl = originals(sys.argv[1]), originals(sys.argv[2])
assert len(photo) == len(styl) == 13, (len(photo), len(styl))
paving = [k for k in range(13) if photo[k] == styl[k]]
assert len(paving) == 1, f"expected only the paving unchanged, got {paving}"
for k in range(13):
    if k in paving: continue
    share, colours = two_colour_share(styl[k])
    assert colours > 1, f"stylised texture {k} has no window"
    assert share >= 0.98, f"stylised texture {k}: two colours on only {share:.3f} of its pixels"
    photo_share, _ = two_colour_share(photo[k])
    assert photo_share < 0.9, f"photo texture {k} passes the two-colour check ({photo_share:.3f}): the check is vacuous"
print("ok: 12 stylised facades are two colours on >= 98 % of their pixels (photos: < 90 %); the paving is unchanged")
PY

"$CITYATLAS" build town/town.gml -o again -q --facades stylised > /dev/null || fail "second build failed"
"$PY" - styl again <<'PY'
import filecmp, os, sys
a, b = sys.argv[1:3]
for root, _, files in os.walk(a):
    for f in files:
        p = os.path.join(root, f); q = os.path.join(b, os.path.relpath(p, a))
        if f == "build_report.json": continue
        assert filecmp.cmp(p, q, shallow=False), f"{p} differs between two identical builds"
print("ok: the same build twice gives the same folder")
PY

# The fingerprint lists the photos behind the stylised facades (not the
# generated files, which live in the working folder): unchanged is up to
# date, an edited photo rebuilds.
"$CITYATLAS" build town/town.gml -o again --facades stylised > again.txt 2>&1 || fail "third build failed"
grep -q "is up to date" again.txt || { cat again.txt >&2; fail "an unchanged stylised build is not up to date"; }
"$PY" -c "from PIL import Image; p='town/textures/facade_000003.png'; im = Image.open(p); im.putpixel((5, 5), (0, 255, 0)); im.save(p)"
"$CITYATLAS" build town/town.gml -o again --facades stylised > again.txt 2>&1 || fail "rebuild failed"
grep -q "rebuilding again: texture town/textures/facade_000003.png changed" again.txt ||
  { cat again.txt >&2; fail "an edited facade photo did not rebuild"; }
echo "ok: up to date when unchanged; an edited photo rebuilds"

BERLIN="$SRC/../shared/data/citygml2_textured_berlin_vcs_export/export.gml"
if [ -f "$BERLIN" ]; then
  "$CITYATLAS" build "$BERLIN" -o berlin --facades stylised > berlin.txt 2>&1 || { cat berlin.txt >&2; fail "Berlin build failed"; }
  line=$(grep -o "stylised facades: .*" berlin.txt)
  tilted=$(echo "$line" | sed -E 's/.*\(([0-9]+) not upright.*/\1/')
  [ "$tilted" -gt 40 ] || fail "Berlin: expected most of its facade crops not upright, got: $line"
  echo "ok: Berlin: $line"
else
  echo "skip: ../shared/data absent (Berlin's oblique facade crops not checked)"
fi

if "$CITYATLAS" build town/town.gml -o bad --facades cartoon > bad.txt 2>&1; then fail "--facades cartoon accepted"; fi
grep -q "facades" bad.txt || { cat bad.txt >&2; fail "the refusal does not name --facades"; }
[ ! -e bad ] || fail "a refused build left a folder"
echo "ok: --facades cartoon refused: $(head -1 bad.txt)"
