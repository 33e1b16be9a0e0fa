# The occlusion lens's occluders, computed independently of the client
# (render/core/lenses.cpp) for tests/cli/render_lenses.sh: a building occludes
# the building of interest when its box meets a segment from the camera to a
# point of a 3 x 3 x 3 grid over the other's box (papers/003 eq. 3.18), or
# when it is near the viewer: its box centre within sphere_r of the camera
# ("sphere", eq. 3.16) or of the camera's vertical line ("cylinder"), or
# within the sphere with the box reaching from below to above the camera's
# height ("viewer_height", eq. 3.17). Every camera path's up is z.
# Boxes are (min x, min y, min z, max x, max y, max z).
import math


def meets(a, b, lo, hi):
    """The segment a-b meets the box [lo, hi] (a slab walk)."""
    t0, t1 = 0.0, 1.0
    for k in range(3):
        d = b[k] - a[k]
        if d == 0:
            if a[k] < lo[k] or a[k] > hi[k]:
                return False
            continue
        ta, tb = (lo[k] - a[k]) / d, (hi[k] - a[k]) / d
        ta, tb = min(ta, tb), max(ta, tb)
        t0, t1 = max(t0, ta), min(t1, tb)
        if t0 > t1:
            return False
    return True


def grid(box):
    lo, hi = box[:3], box[3:]
    steps = [0.02 + 0.48 * i for i in range(3)]
    return [[lo[k] + f[k] * (hi[k] - lo[k]) for k in range(3)] for f in [(i, j, k) for i in steps for j in steps for k in steps]]


def near(b, cam, sphere_r, test):
    if sphere_r <= 0:
        return False
    centre = [(b[k] + b[k + 3]) / 2 for k in range(3)]
    if test == "cylinder":
        return math.hypot(centre[0] - cam[0], centre[1] - cam[1]) < sphere_r
    if math.dist(centre, cam) >= sphere_r:
        return False
    return test == "sphere" or b[2] <= cam[2] <= b[5]


def occluders(boxes, poi, cam, sphere_r=0.0, test="sphere"):
    """The set of building indices that occlude `poi` seen from `cam`."""
    targets = grid(boxes[poi])
    out = set()
    for i, b in enumerate(boxes):
        if i == poi:
            continue
        if near(b, cam, sphere_r, test) or any(meets(cam, g, b[:3], b[3:]) for g in targets):
            out.add(i)
    return out
