# Every dataset in ../shared/data, exported to 3D Tiles (--format 3dtiles,
# other parameters at their defaults), loads completely in both real clients
# (the three.js viewer and CesiumJS, headless chromium), each flying to the
# tileset by itself: no console error, no failed request, every tile that
# loaded drawn from its GLB; where the export has leaves' close-range tiles,
# both clients draw some of them at street level. Figures in
# $WORK/web_shared_data.tsv.
source "$(dirname "$0")/lib.sh" "$@"
DATA="$SRC/../shared/data"
if [ ! -d "$DATA" ]; then echo "SKIP: $DATA is absent (the team's shared data folder)"; exit 77; fi
ensure_browser
shared_inputs "$DATA"
printf 'dataset\tclient\tready_ms\ttiles_loaded\ttiles_drawn\n' > "$WORK/web_shared_data.tsv"
n=0
for in in "${INPUTS[@]}"; do
  if [ -d "$in" ]; then name="$(basename "$in")"; else name="$(basename "$(dirname "$in")")/$(basename "$in")"; fi
  out="t_$n"; n=$((n + 1))
  "$CITYATLAS" build "$in" -o "$out" -q --format 3dtiles > /dev/null 2> "$out.err" || { cat "$out.err" >&2; fail "$name: build failed"; }
  line="ok: $name:"
  for client in three cesium; do
    node "$BROWSER_TOOLS/drive.mjs" --client "$client" --folder "$out" --size 480x270 --out "$out.$client.json" \
      --timeout 180 > "$out.$client.txt" 2>&1 || { cat "$out.$client.txt" >&2; head -c 2000 "$out.$client.json" >&2 2>/dev/null; fail "$name: $client"; }
    read -r ms loaded drawn s < <(json "$out.$client.json" "'%d %d %d %.1f' % (j['state']['ready_ms'], j['state']['tiles_loaded'], j['state']['tiles_visible'], j['state']['ready_ms'] / 1000)")
    [ "$loaded" -gt 0 ] && [ "$drawn" -gt 0 ] || fail "$name: $client loaded $loaded tiles and drew $drawn"
    printf '%s\t%s\t%s\t%s\t%s\n' "$name" "$client" "$ms" "$loaded" "$drawn" >> "$WORK/web_shared_data.tsv"
    line="$line $client $loaded tiles in $s s;"
  done
  # Where leaves have a close range (textures below the leaf's atlas resolution), a street-level
  # camera (1.7 m above the ground near the centre) sees both clients draw some of it.
  if [ "$(json "$out/build_report.json" "j['tiles3d']['originals_tiles']")" -gt 0 ]; then
    "$PY" "$BROWSER_TOOLS/camera.py" "$out/3dtiles/tileset.json" street --camera "$out.street.json"
    line="$line street:"
    for client in three cesium; do
      node "$BROWSER_TOOLS/drive.mjs" --client "$client" --folder "$out" --camera "$out.street.json" --size 480x270 \
        --out "$out.street.$client.json" --timeout 180 > "$out.street.$client.txt" 2>&1 ||
        { cat "$out.street.$client.txt" >&2; fail "$name: $client at street level"; }
      read -r drawn close < <(json "$out.street.$client.json" "'%d %d' % (j['state']['tiles_visible'], sum('_originals.glb' in u for u in j['state'].get('visible_uris', [])))")
      [ "$close" -gt 0 ] || fail "$name: $client draws no leaf's close range at street level ($drawn tiles drawn)"
      printf '%s\t%s street\t%s\t%s\t%s\n' "$name" "$client" "$(json "$out.street.$client.json" "j['state']['ready_ms']")" \
        "$(json "$out.street.$client.json" "j['state']['tiles_loaded']")" "$drawn" >> "$WORK/web_shared_data.tsv"
      line="$line $client $drawn tiles drawn, $close close range;"
    done
  fi
  echo "$line"
done
echo "ok: $n datasets load completely in the three.js viewer and in CesiumJS"
