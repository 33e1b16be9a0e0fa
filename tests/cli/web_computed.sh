# Computed textures in CesiumJS (issue 19: "Cesium users can colour by
# sky-view factor too"): a town built with --computed sky_view --format both
# loads in CesiumJS (Debian's chromium, headless, SwiftShader; driven by
# tests/tools/browser/drive.mjs) with no error, coloured through a
# CustomShader that reads fsInput.metadata.sky_view (the export's
# EXT_structural_metadata property textures) and applies cityatlas' ramp
# (render/core/computed_ramp.h's four stops, written again in the page); its
# screenshot matches `cityatlas render --computed sky_view --computed-mode
# ramp` of the same camera: silhouette IoU >= 0.95, PSNR over the pixels both
# cover >= 25 dB at half resolution (the bar of cli.web_clients); the photo
# against the ramp stays far below it (the bar is not vacuous).
source "$(dirname "$0")/lib.sh" "$@"
ensure_browser
DRIVE="$BROWSER_TOOLS/drive.mjs"
SIZE=640x360
"$CITYATLAS" synth -q --buildings 60 --lod 2 --seed 1 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o out --format both --unique-charts --computed sky_view:directions=16 > /dev/null
"$PY" "$BROWSER_TOOLS/camera.py" out/tileset.json oblique:0.4 --path path.json --camera camera.json
"$CITYATLAS" render out --path path.json --size "$SIZE" --wait --frames 1 -o ramp -q --computed sky_view --computed-mode ramp
"$CITYATLAS" render out --path path.json --size "$SIZE" --wait --frames 1 -o photo -q
node "$DRIVE" --client cesium --folder out --camera camera.json --size "$SIZE" --metadata sky_view \
  --screenshot cesium.png --out cesium.json --timeout 240 > cesium.txt 2>&1 ||
  { cat cesium.txt >&2; head -c 3000 cesium.json >&2 2>/dev/null; fail "cesium: did not load completely, or reported errors"; }
cat cesium.txt
half() { oiiotool "$1" --resize:filter=box 50% -o "$2"; }
half cesium.png cesium_half.png; half ramp/frame_00000.png ramp_half.png; half photo/frame_00000.png photo_half.png
"$IMAGE_COMPARE" cesium.png ramp/frame_00000.png 196,218,243 > full.json
"$IMAGE_COMPARE" cesium_half.png ramp_half.png 196,218,243 > half.json
"$IMAGE_COMPARE" photo_half.png ramp_half.png 196,218,243 > photo.json
"$PY" - <<'PY' || fail "CesiumJS's sky-view colours do not match cityatlas render's"
import json
full, half, photo = (json.load(open(f)) for f in ("full.json", "half.json", "photo.json"))
print(f"CesiumJS (CustomShader on the property textures) vs cityatlas render --computed-mode ramp: silhouette IoU "
      f"{full['silhouette_iou']:.4f}, PSNR {full['psnr_covered_db']:.2f} dB ({half['psnr_covered_db']:.2f} dB at half "
      f"resolution); the photo vs the ramp: {photo['psnr_covered_db']:.2f} dB")
assert full["silhouette_iou"] >= 0.95 and half["psnr_covered_db"] >= 25, "below the bar"
assert photo["psnr_covered_db"] < 20, "the photo passes for the ramp: the comparison cannot tell them apart"
PY
echo "ok: CesiumJS colours the town by sky-view factor from the property textures as cityatlas does"
