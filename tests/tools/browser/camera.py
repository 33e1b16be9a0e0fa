#!/usr/bin/env python3
"""One camera for `cityatlas render` and the browser clients (drive.mjs):

    camera.py TILESET.json VIEW [--path PATH.json] [--camera CAMERA.json]

TILESET.json: the native or the 3D Tiles tileset.json (same root box and
transform). VIEW: oblique:S (over the town from the south, at S times the
root box's larger half extent; 1 shows the whole town) or street (1.7 m above
the box's floor near its centre, looking north). --path writes a one-keyframe
camera path in the local frame (z up, for `render --path`); --camera writes
{position, direction, up, fov_deg} in the tileset's world frame (the root
transform applied: ECEF when georeferenced), for drive.mjs.
"""
import argparse
import json
import math


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("tileset")
    ap.add_argument("view")
    ap.add_argument("--path")
    ap.add_argument("--camera")
    a = ap.parse_args()
    t = json.load(open(a.tileset))
    b = t["root"]["boundingVolume"]["box"]
    c, hx, hy, hz = b[0:3], b[3], b[7], b[11]
    if a.view.startswith("oblique:"):
        r = float(a.view.split(":")[1]) * max(hx, hy)
        pos = [c[0], c[1] - 1.1 * r, c[2] + hz + 0.9 * r]
        d = [0.0, 1.0 * r, -(hz + 0.9 * r)]
    elif a.view == "street":
        pos = [c[0] + 0.5, c[1] - 0.3 * hy, c[2] - hz + 1.7]
        d = [0.0, 1.0, -0.05]
    else:
        raise SystemExit(f"camera.py: unknown view {a.view} (oblique:S or street)")
    if a.path:
        json.dump({"frame_rate": 1, "keyframes": [{"time_s": 0, "position": pos, "direction": d, "fov_deg": 60}]},
                  open(a.path, "w"))
    M = t["root"].get("transform")

    def apply(v, point):
        if not M:
            return list(v)
        return [sum(M[4 * k + i] * v[k] for k in range(3)) + (M[12 + i] if point else 0) for i in range(3)]

    def unit(v):
        n = math.sqrt(sum(x * x for x in v))
        return [x / n for x in v]

    dw, uw = unit(apply(d, False)), apply([0, 0, 1], False)
    dot = sum(p * q for p, q in zip(uw, dw))
    if a.camera:
        json.dump({"position": apply(pos, True), "direction": dw,
                   "up": unit([u - dot * x for u, x in zip(uw, dw)]), "fov_deg": 60}, open(a.camera, "w"))


if __name__ == "__main__":
    main()
