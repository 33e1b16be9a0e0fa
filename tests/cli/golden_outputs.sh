# Goldens: `cityatlas inspect --json` of a few small builds must equal the
# files in tests/golden, so an unintended change of output shows as a diff.
# After an intended change, regenerate them and review the diff:
#   CITYATLAS_UPDATE_GOLDENS=1 ctest -R cli.golden_outputs   (then git diff tests/golden)
# Also: a build with 1 thread and with 4 gives byte-identical folders
# (tiles/tileset.h promises that the output does not depend on threads).
source "$(dirname "$0")/lib.sh" "$@"
GOLDEN="$SRC/tests/golden"
UPDATE="${CITYATLAS_UPDATE_GOLDENS:-0}"

golden() {  # golden NAME FOLDER: compares (or, updating, writes) NAME.json
  "$CITYATLAS" inspect --json "$2" > "$1.json" || { head -c 2000 "$1.json" >&2; fail "$1: inspect --json found defects"; }
  if [ "$UPDATE" = 1 ]; then
    cp "$1.json" "$GOLDEN/$1.json"
    echo "updated: tests/golden/$1.json"
  elif ! diff -u "$GOLDEN/$1.json" "$1.json" > "$1.diff"; then
    head -60 "$1.diff" >&2
    fail "$1: the output differs from tests/golden/$1.json ($(grep -c '^[-+][^-+]' "$1.diff") lines); if intended: CITYATLAS_UPDATE_GOLDENS=1 ctest -R cli.golden_outputs"
  else
    echo "ok: $1 equals its golden ($(wc -c < "$1.json") bytes of canonical JSON)"
  fi
}

# 1. A deeper tree: LOD1 with the orthophoto on its roofs, d_min forced down.
"$CITYATLAS" synth -q --lod 1 --buildings 30 --seed 8 --texture-size 32 --orthophoto world-file -o lod1 > /dev/null
"$CITYATLAS" build -q lod1/town.gml -o lod1_out --d-min 40 --threads 1 > /dev/null
# 1 vs 4 threads: every file byte-identical (the build report holds times).
"$CITYATLAS" build -q lod1/town.gml -o lod1_out4 --d-min 40 --threads 4 > /dev/null
diff -rq -x build_report.json lod1_out lod1_out4 > threads.diff || { cat threads.diff >&2; fail "1 and 4 threads give different folders"; }
echo "ok: 1 and 4 threads give byte-identical folders ($(find lod1_out -type f | wc -l) files)"
golden lod1_orthophoto_deep lod1_out
[ "$(json lod1_out/tileset.json "j['extras']['cityatlas']['totals']['depth']")" -ge 1 ] || fail "case 1 is meant to have several levels"

# 2. The product at defaults: a small LOD2 town, default d_min.
"$CITYATLAS" synth -q --buildings 24 --seed 3 --texture-size 32 -o lod2 > /dev/null
"$CITYATLAS" build -q lod2/town.gml -o lod2_out > /dev/null
golden lod2_default lod2_out

# 3. Footprints: the shapefile of town 2, extruded.
"$CITYATLAS" build -q lod2/footprints.shp -o shp_out > /dev/null
golden footprints_default shp_out

