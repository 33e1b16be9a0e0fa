# The client's RAM level (issue 18, the spec's H2): street view A, a cut to
# street view B at the other end of the town, a cut back to A, each frame
# waiting for its ideal set, with a GPU budget that holds one view's ideal
# set but not both:
# - without the RAM level (--ram-budget 0) coming back to A fetches again;
# - with a RAM budget of at least both ideal sets, coming back to A fetches
#   0 bytes (exact), served by RAM hits;
# - on every frame RAM <= its budget, and resident + pinned <= the budget;
# - a RAM budget too small for both views still holds its invariant.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth --buildings 30 --seed 3 --texture-size 128 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 -q > /dev/null
"$PY" - <<'PY'
import json
t = json.load(open("tiles/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
z0 = c[2] - hz
A = {"position": [c[0], c[1] - hy - 5, z0 + 1.7], "look_at": [c[0], c[1], z0 + 5]}
B = {"position": [c[0], c[1] + hy + 5, z0 + 1.7], "look_at": [c[0], c[1], z0 + 5]}
keys = [dict(A, time_s=0, label="A"), dict(A, time_s=2),
        dict(B, time_s=3, cut=True, label="B"), dict(B, time_s=5),
        dict(A, time_s=6, cut=True, label="A again"), dict(A, time_s=8)]
json.dump({"interpolation": "linear", "frame_rate": 1, "keyframes": keys}, open("path.json", "w"), indent=1)
PY
run() {  # run NAME BUDGET RAM_BUDGET
  "$CITYATLAS" render tiles --path path.json --size 320x240 --wait --anisotropy 1 --budget "$2" --ram-budget "$3" -o "$1" -q
  "$PY" -c "import json,jsonschema,sys; jsonschema.validate(json.load(open('$1/report.json')), json.load(open(sys.argv[1])), cls=jsonschema.Draft7Validator)" \
    "$SRC/schemas/render_report.schema.json" || fail "$1/report.json does not match its schema"
}
# Frames: 0-2 at A, 3-5 at B, 6-8 at A again (a cut shows at its key's frame).
run big 4G 0
ideal_a=$(json big/report.json "max(f['ideal_bytes'] for f in j['frames'][0:3])")
ideal_b=$(json big/report.json "max(f['ideal_bytes'] for f in j['frames'][3:6])")
pinned=$(json big/report.json "j['frames'][0]['pinned_bytes']")
gpu=$(( pinned + (ideal_a > ideal_b ? ideal_a : ideal_b) ))
echo "ideal set at A $ideal_a bytes, at B $ideal_b, bounds $pinned: GPU budget $gpu"

run off "$gpu" 0
run on "$gpu" $(( ideal_a + ideal_b ))
run small "$gpu" $(( (ideal_a + ideal_b) / 3 ))
for r in off on small; do
  check_eq "$r: frames with resident + pinned over the budget" "0" \
    "$(json $r/report.json "sum(f['resident_bytes'] + f['pinned_bytes'] > f['budget_bytes'] for f in j['frames'])")"
  check_eq "$r: frames with the RAM level over its budget" "0" \
    "$(json $r/report.json "sum(f['ram_bytes'] > f['ram_budget_bytes'] for f in j['frames'])")"
  check_eq "$r: every frame's ideal set complete" "True" "$(json $r/report.json "all(f['ideal_set_complete'] for f in j['frames'])")"
done
check_eq "the GPU budget holds each view's whole ideal set" "False" \
  "$(json off/report.json "any(f['refinement']['ideal_cut_by_budget'] for f in j['frames'])")"
again_off=$(json off/report.json "sum(f['bytes_loaded'] for f in j['frames'][6:])")
again_on=$(json on/report.json "sum(f['bytes_loaded'] for f in j['frames'][6:])")
hits_on=$(json on/report.json "sum(f['ram_hits'] for f in j['frames'][6:])")
[ "$again_off" -gt 0 ] || fail "without the RAM level, coming back to A fetched nothing: the budget did not force evictions"
check_eq "with the RAM level, bytes fetched coming back to A" "0" "$again_on"
[ "$hits_on" -gt 0 ] || fail "coming back to A had no RAM hits"
check_eq "off: no RAM hits" "0" "$(json off/report.json "sum(f['ram_hits'] for f in j['frames'])")"
echo "ok: back at A: $again_off bytes fetched without the RAM level, 0 with it ($hits_on RAM hits)"
