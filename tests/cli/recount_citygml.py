#!/usr/bin/python3
"""Recounts a synthetic town's CityGML independently of cityatlas's C++ code
and compares with its truth.json.

Parses the file with ElementTree, and per gml:Polygon counts rings and
vertices, derives the triangle count V + 2H - 2 and the area (Newell normal
of each ring, holes subtracted), grouped by thematic surface (LOD2) or, for
LOD1 solids, by the direction the polygon faces. Also checks that every
polygon is closed and that texture coordinates and rings match in length.
Usage: recount_citygml.py TOWN_DIR
"""
import json
import math
import sys
import xml.etree.ElementTree as ET

GML = "{http://www.opengis.net/gml}"
BLDG = "{http://www.opengis.net/citygml/building/2.0}"
APP = "{http://www.opengis.net/citygml/appearance/2.0}"
THEMATIC = {BLDG + "WallSurface": "wall", BLDG + "RoofSurface": "roof", BLDG + "GroundSurface": "ground"}


def ring_points(ring):
    pos_list = ring.find(GML + "posList")
    if pos_list is not None:
        v = [float(x) for x in pos_list.text.split()]
    else:
        v = [float(x) for p in ring.findall(GML + "pos") for x in p.text.split()]
    pts = [tuple(v[i:i + 3]) for i in range(0, len(v), 3)]
    if pts[0] != pts[-1]:
        raise SystemExit(f"FAIL: ring {ring.get(GML + 'id')} is not closed")
    return pts[:-1]


def newell(pts):
    o = pts[0]
    nx = ny = nz = 0.0
    for i in range(len(pts)):
        a = [pts[i][k] - o[k] for k in range(3)]
        b = [pts[(i + 1) % len(pts)][k] - o[k] for k in range(3)]
        nx += (a[1] - b[1]) * (a[2] + b[2])
        ny += (a[2] - b[2]) * (a[0] + b[0])
        nz += (a[0] - b[0]) * (a[1] + b[1])
    return nx, ny, nz


def main():
    town = sys.argv[1]
    truth = json.load(open(f"{town}/truth.json"))
    root = ET.parse(f"{town}/{truth['files']['citygml']}").getroot()

    # Which surface kind each polygon is.
    kind_of = {}
    for el in root.iter():
        if el.tag in THEMATIC:
            for poly in el.iter(GML + "Polygon"):
                kind_of[poly.get(GML + "id")] = THEMATIC[el.tag]

    tally = {}
    ring_sizes = {}
    for poly in root.iter(GML + "Polygon"):
        pid = poly.get(GML + "id")
        rings = [poly.find(GML + "exterior/" + GML + "LinearRing")] + \
                [r.find(GML + "LinearRing") for r in poly.findall(GML + "interior")]
        pts = [ring_points(r) for r in rings]
        for r, p in zip(rings, pts):
            ring_sizes[r.get(GML + "id")] = len(p)
        n = newell(pts[0])
        area = math.sqrt(sum(c * c for c in n)) / 2 - sum(math.sqrt(sum(c * c for c in newell(h))) / 2 for h in pts[1:])
        kind = kind_of.get(pid)
        if kind is None:  # LOD1: what the geometry implies
            length = math.sqrt(sum(c * c for c in n))
            kind = "roof" if n[2] > 0.5 * length else "ground" if n[2] < -0.5 * length else "wall"
        t = tally.setdefault(kind, {"polygons": 0, "interior_rings": 0, "vertices": 0, "triangles": 0, "area_m2": 0.0})
        t["polygons"] += 1
        t["interior_rings"] += len(pts) - 1
        t["vertices"] += sum(len(p) for p in pts)
        t["triangles"] += sum(len(p) for p in pts) + 2 * (len(pts) - 1) - 2
        t["area_m2"] += area

    failures = 0
    for kind, t in sorted(tally.items()):
        want = truth["surfaces"].get(kind)
        if want is None:
            print(f"FAIL: {kind} polygons in the file but not in truth.json"); failures += 1; continue
        for key in ("polygons", "interior_rings", "vertices", "triangles"):
            if t[key] != want[key]:
                print(f"FAIL: {kind} {key}: file {t[key]}, truth {want[key]}"); failures += 1
        rel = abs(t["area_m2"] - want["area_m2"]) / want["area_m2"]
        if rel > 1e-9:
            print(f"FAIL: {kind} area: file {t['area_m2']}, truth {want['area_m2']} (rel {rel:.2e})"); failures += 1
        print(f"ok: {kind}: {t['polygons']} polygons, {t['triangles']} triangles, {t['area_m2']:.3f} m2 (rel diff {rel:.1e})")
    if set(tally) != set(truth["surfaces"]):
        print(f"FAIL: surface kinds differ: file {sorted(tally)}, truth {sorted(truth['surfaces'])}"); failures += 1

    # Texture coordinates: one (u, v) per ring vertex plus the closing one.
    textured = 0
    for tc in root.iter(APP + "textureCoordinates"):
        ring = tc.get("ring").lstrip("#")
        n = len(tc.text.split()) // 2
        if ring not in ring_sizes or n != ring_sizes[ring] + 1:
            print(f"FAIL: texture coordinates for ring {ring}: {n} pairs"); failures += 1
    for pt in root.iter(APP + "ParameterizedTexture"):
        textured += len(pt.findall(APP + "target"))
    coloured = sum(len(m.findall(APP + "target")) for m in root.iter(APP + "X3DMaterial"))
    for name, got in (("textured_polygons", textured), ("coloured_polygons", coloured)):
        if got != truth[name]:
            print(f"FAIL: {name}: file {got}, truth {truth[name]}"); failures += 1
        else:
            print(f"ok: {name} = {got}")
    sys.exit(1 if failures else 0)


main()
