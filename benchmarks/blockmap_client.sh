#!/usr/bin/env bash
# Issue 20's client benchmark: a folder built with --blockmaps complement,
# drawn by `cityatlas render` on this machine's GL (Mesa llvmpipe without a
# GPU) along the default path, every frame with its ideal set loaded
# (--wait; frame times exclude loading), with BlockMaps on and off (a
# folder built with --blockmaps replace: on alone):
#   - mean, median and worst frame time, nodes drawn (BlockMaps among them),
#     triangles, bytes loaded over the path and the most resident at once;
#   - bytes to the first complete frame (the overview);
#   - bytes per level: BlockMaps against geometry and atlases.
# One BlockMap full screen (the ray caster's worst case, closer than any
# BlockMap is drawn) is benchmarks/blockmap_spike.sh's `close` camera.
# Usage: benchmarks/blockmap_client.sh FOLDER [SIZE=1280x720] [FPS=2]
# Writes out/benchmarks/blockmap-client-<folder name>.json and prints a table.
# Folders: cityatlas build out/benchmarks/synth-10000-512/town.gml -o out/benchmarks/bm-10000
#   --d-min 400 --blockmaps complement (benchmarks/build_scale.sh makes the town).
set -euo pipefail
cd "$(dirname "$0")/.."
TILES="${1:?usage: benchmarks/blockmap_client.sh FOLDER [SIZE] [FPS]}"; SIZE="${2:-1280x720}"; FPS="${3:-2}"
./scripts/build > /dev/null
[ -f "$TILES/tileset.json" ] || { echo "no tile folder at $TILES" >&2; exit 1; }
NAME=$(basename "$TILES")
OUT="out/benchmarks/blockmap-client-$NAME"; mkdir -p "$OUT"
/usr/bin/python3 - "$TILES" "$SIZE" "$FPS" "$OUT" <<'PY'
import json, math, os, subprocess, sys, time
tiles, size, fps, out = sys.argv[1:5]
t = json.load(open(os.path.join(tiles, "tileset.json")))
root = t["root"]
if "blockmap" not in root["extras"]["cityatlas"]:
    sys.exit(f"{tiles}: the root has no BlockMap (build --blockmaps complement or replace)")
def render(name, extra):
    report = os.path.join(out, name + ".json")
    cmd = ["./build/cli/cityatlas", "render", tiles, "--anisotropy", "1", "--size", size, "--wait", "--report", report, "-q"] + extra
    t0 = time.monotonic()
    subprocess.run(cmd, check=True)
    r = json.load(open(report))
    s, frames = r["summary"], r["frames"]
    first = next((f for f in frames if f["ideal_set_complete"]), frames[0])
    return {"run": name, "command": " ".join(cmd), "wall_s": round(time.monotonic() - t0, 1), "frames": s["frames"],
            "frame_ms_mean": round(s["frame_ms_mean"], 2), "frame_ms_median": round(s["frame_ms_median"], 2),
            "frame_ms_max": round(s["frame_ms_max"], 2),
            "nodes_drawn_mean": round(s["nodes_drawn_mean"], 1),
            "blockmaps_drawn_mean": round(sum(f["nodes_drawn"]["blockmap"] for f in frames) / len(frames), 1),
            "triangles_mean": round(sum(f["triangles"] for f in frames) / len(frames)),
            "bytes_loaded": s["bytes_loaded"], "resident_bytes_max": s["resident_bytes_max"],
            "bytes_to_first_frame": first["bytes_loaded"], "errors": s["errors"], "renderer": r["gl"]["renderer"]}
# A first pass warms the page cache (the first run of a cold folder read
# its files while drawing: 370 against 140 ms a frame on the 10,000-building
# town); then each setting twice, alternating, the second of each kept.
# A folder built with --blockmaps replace cannot be drawn without its BlockMaps: its run alone.
replace = t["extras"]["cityatlas"]["build"].get("blockmaps") == "replace"
render("warm-up", ["--fps", fps] + ([] if replace else ["--blockmaps", "off"]))
for _ in range(2):
    runs = [render("path-blockmaps", ["--fps", fps])] + ([] if replace else [render("path-geometry", ["--fps", fps, "--blockmaps", "off"])])
levels = {}
def walk(tile, level):
    ca = tile["extras"]["cityatlas"]
    l = levels.setdefault(level, {"nodes": 0, "geometry_atlases": 0, "blockmaps": 0, "blockmap_bytes": 0})
    l["nodes"] += 1
    l["geometry_atlases"] += ca["bytes"]
    if "blockmap" in ca:
        l["blockmaps"] += 1; l["blockmap_bytes"] += ca["blockmap"]["bytes"]
    for ch in tile.get("children", []): walk(ch, level + 1)
walk(root, 0)
json.dump({"folder": tiles, "size": size, "runs": runs, "bytes_per_level": levels}, open(out + ".json", "w"), indent=1)
print(f"{'run':16s} {'mean':>8s} {'median':>8s} {'worst':>8s} {'nodes':>6s} {'BMs':>5s} {'triangles':>10s} {'loaded MB':>10s} {'first MB':>9s}")
for r in runs:
    print(f"{r['run']:16s} {r['frame_ms_mean']:8.2f} {r['frame_ms_median']:8.2f} {r['frame_ms_max']:8.2f} {r['nodes_drawn_mean']:6.1f} "
          f"{r['blockmaps_drawn_mean']:5.1f} {r['triangles_mean']:10d} {r['bytes_loaded'] / 1e6:10.1f} {r['bytes_to_first_frame'] / 1e6:9.2f}")
print("level  nodes  geometry+atlases MB  BlockMaps  their MB")
for k in sorted(levels):
    l = levels[k]
    print(f"{k:5d} {l['nodes']:6d} {l['geometry_atlases'] / 1e6:20.2f} {l['blockmaps']:10d} {l['blockmap_bytes'] / 1e6:9.2f}")
print(f"renderer: {runs[0]['renderer']}; written {out}.json")
PY
