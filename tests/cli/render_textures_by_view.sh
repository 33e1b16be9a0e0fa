# Texture blocks by view (issue 18: "a street-level view loads only the tiles
# it sees"; papers/004 §2): a leaf drawn with its originals loads only the
# texture blocks its decoded geometry samples on screen and closer than its
# min distance (render/core/selection.h, SelectionParams::texture_use). On a
# town of 1024 px facades built with --split-originals on and otherwise
# default settings, the default flight (overview, oblique, street), every
# frame with its ideal set loaded, with --textures-by-view on (the default)
# and off:
# - every street-level frame drawing originals needs fewer bytes (needed_bytes:
#   the Needed blocks of its ideal set), and the flight loads >= 10 % fewer;
# - the pictures stay: what is not loaded any more is off screen, or farther
#   than the leaf's min distance where its atlas is sharp enough and stands in
#   for the original; at most 1 % of a frame's pixels differ by more than 8 LSB;
# - the report validates against its schema and says textures_by_view.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth -q --lod 2 --buildings 40 --seed 3 --texture-size 1024 -o town > /dev/null
"$CITYATLAS" build -q town/town.gml -o tiles --split-originals on > /dev/null
for v in on off; do
  "$CITYATLAS" render tiles --size 480x270 --wait --anisotropy 1 --textures-by-view $v --every 10 -o r_$v -q
done
validate_json r_on/report.json "$SRC/schemas/render_report.schema.json" || fail "report.json does not match its schema"
check_eq "settings.textures_by_view" "True False" \
  "$(json r_on/report.json "j['settings']['textures_by_view']") $(json r_off/report.json "j['settings']['textures_by_view']")"
"$PY" - <<'PY' || fail "textures by view (above)"
import json, sys
from PIL import Image, ImageChops
on, off = (json.load(open(f"r_{v}/report.json")) for v in ("on", "off"))
bad = False
def check(ok, what):
    global bad
    print(("ok: " if ok else "FAIL: ") + what); bad |= not ok
street = [(a, b) for a, b in zip(on["frames"], off["frames"]) if a["label"] == "street" and b["nodes_drawn"]["originals"] > 0]
fewer = [a["needed_bytes"] < b["needed_bytes"] for a, b in street]
saved = [1 - a["needed_bytes"] / b["needed_bytes"] for a, b in street]
check(len(street) >= 20 and all(fewer),
      f"{sum(fewer)} of {len(street)} street frames drawing originals need fewer bytes ({min(saved):.0%}..{max(saved):.0%} less)")
lo, lf = on["summary"]["bytes_loaded"], off["summary"]["bytes_loaded"]
check(lo <= 0.9 * lf, f"the flight loads {lo} bytes by view, {lf} without ({1 - lo / lf:.0%} less)")
worst = 0
for a, b in zip(on["frames"], off["frames"]):
    if not a["image"]:
        continue
    d = ImageChops.difference(Image.open("r_on/" + a["image"]).convert("RGB"), Image.open("r_off/" + b["image"]).convert("RGB"))
    px = [max(p) for p in d.getdata()]
    worst = max(worst, sum(p > 8 for p in px) / len(px))
check(worst <= 0.01, f"at most {worst:.2%} of a frame's pixels differ by more than 8 LSB")
sys.exit(1 if bad else 0)
PY
