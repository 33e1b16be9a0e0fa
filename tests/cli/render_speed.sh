# The client's speed policies (issue 18, the spec's H3): a street-level hold,
# a 200 m/s run along the street, a hold again, each frame waiting for its
# ideal set (so the counts do not depend on timing):
# - with --speed-limit 40, the fast frames request no original-texture block
#   (exact) and are marked speed_limited; the policy off requests some there;
# - after slowing down, the same frames as without the policy (the ideal set
#   is the full one again), with the budget held throughout;
# - --tau-speed asks for less while fast (smaller ideal sets: coarser atlases
#   are sharp enough) and the same at rest;
# - --lookahead-s asks for more while moving (what the camera will need) and
#   the same at rest.
source "$(dirname "$0")/lib.sh" "$@"

"$CITYATLAS" synth --buildings 30 --seed 3 --texture-size 512 -o town -q > /dev/null
"$CITYATLAS" build town/town.gml -o tiles --d-min 100 -q > /dev/null
"$PY" - <<'PY'
import json
t = json.load(open("tiles/tileset.json"))
b = t["root"]["boundingVolume"]["box"]; c = b[:3]; hx, hy, hz = b[3], b[7], b[11]
z0 = c[2] - hz
def at(x): return {"position": [x, c[1] - hy - 5, z0 + 1.7], "look_at": [x, c[1], z0 + 5]}
x0, x1 = c[0] - 0.9 * hx, c[0] + 0.9 * hx
run_s = (x1 - x0) / 200.0  # 200 m/s
keys = [dict(at(x0), time_s=0, label="slow"), dict(at(x0), time_s=1, label="fast"),
        dict(at(x1), time_s=1 + run_s, label="slow again"), dict(at(x1), time_s=3 + run_s)]
json.dump({"interpolation": "linear", "frame_rate": 10, "keyframes": keys}, open("path.json", "w"), indent=1)
PY
run() {  # run NAME BUDGET ARGS...
  local name=$1 budget=$2; shift 2
  "$CITYATLAS" render tiles --path path.json --size 240x160 --wait --anisotropy 1 --budget "$budget" -o "$name" -q "$@"
}
# A budget of 1.5 times the largest ideal set with everything allowed: the
# run along the street has to load what comes into view.
run probe 4G
budget=$(json probe/report.json "int(1.5 * max(f['ideal_bytes'] for f in j['frames'])) + j['frames'][0]['pinned_bytes']")
run off "$budget"
run limited "$budget" --speed-limit 40
run tau "$budget" --tau-speed 20
run ahead "$budget" --lookahead-s 0.1
"$PY" - <<'PY' || fail "speed policies (above)"
import json, sys
bad = False
def check(ok, what):
    global bad
    print(("ok: " if ok else "FAIL: ") + what); bad |= not ok
def frames(name): return json.load(open(f"{name}/report.json"))["frames"]
off, lim, tau, ahead = frames("off"), frames("limited"), frames("tau"), frames("ahead")
fast = [i for i, f in enumerate(off) if f["speed_mps"] > 40]
slow_after = [i for i, f in enumerate(off) if i > max(fast) + 1]
check(len(fast) >= 5 and all(abs(off[i]["speed_mps"] - 200) < 1 for i in fast[1:-1]),
      f"{len(fast)} frames at ~200 m/s")
check(sum(off[i]["requests"]["textures"] for i in fast) > 0,
      f"policy off: {sum(off[i]['requests']['textures'] for i in fast)} original-texture requests while fast")
check(sum(lim[i]["requests"]["textures"] for i in fast) == 0, "--speed-limit 40: no original-texture request while fast")
check(all(lim[i]["speed_limited"] for i in fast) and not any(f["speed_limited"] for i, f in enumerate(lim) if i not in fast),
      "speed_limited exactly on the fast frames")
check(sum(lim[i]["bytes_loaded"] for i in fast) < sum(off[i]["bytes_loaded"] for i in fast),
      f"bytes loaded while fast: {sum(lim[i]['bytes_loaded'] for i in fast)} with the policy, "
      f"{sum(off[i]['bytes_loaded'] for i in fast)} without")
check(all(lim[i]["ideal_bytes"] == off[i]["ideal_bytes"] and lim[i]["triangles"] == off[i]["triangles"] for i in slow_after[1:]),
      "after slowing down: the same ideal sets and pictures' triangles as without the policy")
check(all(f["resident_bytes"] + f["pinned_bytes"] <= f["budget_bytes"] for f in lim), "budget held")
check(sum(tau[i]["ideal_bytes"] for i in fast) < sum(off[i]["ideal_bytes"] for i in fast),
      f"--tau-speed: ideal sets of {sum(tau[i]['ideal_bytes'] for i in fast)} bytes while fast against {sum(off[i]['ideal_bytes'] for i in fast)}")
check(all(tau[i]["triangles"] == off[i]["triangles"] for i in slow_after[1:]), "--tau-speed: the same frames at rest")
# Look-ahead: while moving, the ideal set also holds what 0.1 s ahead (20 m) needs.
check(all(ahead[i]["refinement"]["ideal_blocks"] >= off[i]["refinement"]["ideal_blocks"] for i in fast)
      and any(ahead[i]["refinement"]["ideal_blocks"] > off[i]["refinement"]["ideal_blocks"] for i in fast),
      f"--lookahead-s: ideal sets while moving {[ahead[i]['refinement']['ideal_blocks'] for i in fast]} against "
      f"{[off[i]['refinement']['ideal_blocks'] for i in fast]}")
check(all(ahead[i]["ideal_bytes"] == off[i]["ideal_bytes"] for i in slow_after[1:]), "--lookahead-s: the same ideal sets at rest")
check(all(f["resident_bytes"] + f["pinned_bytes"] <= f["budget_bytes"] for f in ahead), "--lookahead-s: budget held")
sys.exit(1 if bad else 0)
PY
