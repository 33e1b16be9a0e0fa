#!/usr/bin/env bash
# Issue 20's spike: does a BlockMap (papers/002) pay at the root? For the
# 10,000-building town (benchmarks/build_scale.sh 10000 400 main: 512 px
# facades, --d-min 400) and the 100,000-building one (100000 2000 main 32),
# a root BlockMap at the root's own texel size (tests/tools/blockmap_spike.cpp)
# against the root's geometry and atlases in the built folder:
#   - bytes (zstd planes + BC1 colour, as SEED-FEATURES §1.2 lays them out)
#     and the BlockMap's build seconds (planes and colours from the town's
#     textures), its measured Hausdorff error against the triangles; the
#     same for a BlockMap sampled 4 x 4 per cell (max: conservative);
#   - plan-view built area kept: every building, the root geometry's
#     buildings (it leaves out those smaller than its texel), the BlockMap's
#     occupied cells;
#   - frame time on this machine's GL (llvmpipe without a GPU) at four
#     cameras: `switch` (the root's min distance), `full` (the town fills the
#     frame one way), `close` (all frame is town: the ray caster's worst case,
#     closer than the root is ever drawn), `away` (looking away: the frame's
#     fixed cost). The root's own frames come from `cityatlas render` with a
#     budget that holds the root alone, so it draws the root at every camera;
#   - per level of the folder: buildings the geometry leaves out, and how
#     many of them span 2 or more texels of their node (>= 2 px at its switch);
#   - the same for real data in ../shared/data (London, two NRW tiles,
#     Berlin's textured export), each built at default settings; skipped
#     with a message when the folder is absent.
# Writes out/benchmarks/blockmap-spike.json and prints a table.
# Usage: benchmarks/blockmap_spike.sh [SIZE=1280x720] [FRAMES=10] [docs]
#   docs: also docs/blockmap-spike.png (the 10,000-building root at the
#   `full` camera: its geometry and atlases, then its BlockMap).
# Builds missing towns and folders with benchmarks/build_scale.sh (minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
SIZE="${1:-1280x720}"; FRAMES="${2:-10}"; DOCS="${3:-}"
./scripts/build > /dev/null
ninja -C build blockmap_spike > /dev/null
# The root's own frames: `cityatlas render` with a budget that holds the root alone.
root_frames() {  # FOLDER WORK
  local root_bytes pinned
  root_bytes=$(/usr/bin/python3 -c "import json; print(json.load(open('$2/spike.json'))['root']['bytes'])")
  pinned=$(du -cb "$1"/features/bounds/*.bin | tail -1 | cut -f1)
  ./build/cli/cityatlas render "$1" --path "$2/cameras.json" --size "$SIZE" --fade-s 0 -q \
    --budget $((root_bytes + pinned + 4096)) -o "$2/root-frames" --every 20
}
WORKS=()
TOWNS=("10000 400 512" "100000 2000 32")
for t in "${TOWNS[@]}"; do
  set -- $t
  tag="$1-$2"; [ "$3" = 512 ] || tag="$tag-$3px"
  folder="out/benchmarks/build-$tag-default"
  [ -f "$folder/tileset.json" ] || benchmarks/build_scale.sh "$1" "$2" main "$3"
  work="out/benchmarks/blockmap-spike-$1"
  rm -rf "$work"; mkdir -p "$work"
  ./build/tests/tools/blockmap_spike "$1" "$3" "out/benchmarks/synth-$1-$3" "$folder" "$work" "$SIZE" "$FRAMES" > /dev/null
  root_frames "$folder" "$work"
  WORKS+=("$work")
done
# Real data (../shared/data), each built at default settings.
SHARED="${CITYATLAS_SHARED:-../shared}/data"
if [ -d "$SHARED" ]; then
  for f in citygml2_lod2_london_vcs/London_LOD2.gml citygml1_lod2_nrw_tile/LoD2_32_330_5728_1_NW.gml \
           citygml1_lod1_nrw_tile/LoD1_32_280_5657_1_NW.gml citygml2_textured_berlin_vcs_export/export.gml; do
    name=$(dirname "$f")
    folder="out/benchmarks/blockmap-real-$name-tiles"
    work="out/benchmarks/blockmap-spike-$name"
    ./build/cli/cityatlas build "$SHARED/$f" -o "$folder" --force --overwrite -q > /dev/null
    rm -rf "$work"; mkdir -p "$work"
    # Untextured roots have texels of millimetres: cells of at least 1 m there.
    BLOCKMAP_MIN_CELL_M=1 ./build/tests/tools/blockmap_spike --citygml "$SHARED/$f" "$folder" "$work" "$SIZE" "$FRAMES" > /dev/null
    root_frames "$folder" "$work"
    WORKS+=("$work")
  done
else
  echo "blockmap_spike: $SHARED not found: the real datasets are skipped" >&2
fi
/usr/bin/python3 - "$SIZE" "$DOCS" "${WORKS[@]}" <<'PY'
import json, os, statistics, struct, sys, collections
size, docs, works = sys.argv[1], sys.argv[2] == "docs", sys.argv[3:]
def dropped_per_level(folder):
    widths, base = {}, 0
    bdir = os.path.join(folder, "features", "bounds")
    for f in sorted(os.listdir(bdir), key=lambda f: int(f.split(".")[0])):
        data = open(os.path.join(bdir, f), "rb").read()
        for i in range(len(data) // 32):
            mn, mx = struct.unpack_from("<3f", data, i * 32), struct.unpack_from("<3f", data, i * 32 + 12)
            widths[base + i] = max(mx[0] - mn[0], mx[1] - mn[1])
        base += len(data) // 32
    levels = collections.defaultdict(lambda: {"nodes": 0, "nodes_dropping": 0, "dropped": 0, "dropped_2_texels": 0})
    def walk(n):
        e = n["extras"]["cityatlas"]
        row, d = levels[e["level"]], e["features"].get("dropped", [])
        row["nodes"] += 1; row["nodes_dropping"] += bool(d); row["dropped"] += len(d)
        row["dropped_2_texels"] += sum(1 for f in d if widths.get(f, 0) >= 2 * e["world_texel_m"])
        for c in n.get("children", []): walk(c)
    walk(json.load(open(os.path.join(folder, "tileset.json")))["root"])
    return dict(sorted(levels.items()))
result = {"size": size, "towns": []}
for work in works:
    r = json.load(open(f"{work}/spike.json"))
    frames = json.load(open(f"{work}/root-frames/report.json"))["frames"]
    root_ms = {}
    for cam in ("switch", "full", "close", "away"):
        ok = [f["frame_ms"] for f in frames if f["label"] == cam and f["uploads"] == 0 and not f["root_missing"]]
        root_ms[cam] = round(statistics.median(ok), 2) if ok else None
    r["render_root_geometry"] = root_ms
    r["levels"] = dropped_per_level(r["root"]["folder"])
    result["towns"].append(r)
json.dump(result, open("out/benchmarks/blockmap-spike.json", "w"), indent=1)
print(f"frame {size}, {result['towns'][0]['render']['renderer']}")
for r in result["towns"]:
    b, root, a = r["blockmap"], r["root"], r["plan_area_m2"]
    print(f"\n{r['town']['source']}, {r['town']['buildings']} buildings: root texel {root['world_texel_m']:.3f} m,"
          f" BlockMap cell {r['blockmap']['cell_m']:.2f} m, switch {root['min_distance_m']:.0f} m")
    print(f"  bytes: root geometry+atlases {root['bytes']:,}  BlockMap file {b['bytes']['file']:,}"
          f" (16-bit cell layout estimate {b['bytes']['total']:,}; GPU {b['bytes']['gpu']:,})"
          f"  grid {b['grid'][0]}x{b['grid'][1]}, {b['columns']:,} columns, {b['features']:,} buildings")
    print(f"  BlockMap build {b['build']['total_s']:.2f} s: planes and colours {b['build']['planes_s']:.2f} s"
          f" ({b['build']['colour_rays']:,} colour rays), encode {b['build']['encode_s']:.2f} s;"
          f" measured error {b['build']['hausdorff_m']:.2f} m in {b['build']['error_s']:.1f} s (voxel bound {b['voxel_error_bound_m']:.2f} m;"
          f" the root geometry's simplification error {max(l['geometric_error_m'] for l in root['layers'].values()):.2f} m)")
    m = r["blockmap_max"]
    print(f"  max-sampled BlockMap: {m['features']:,} buildings, {m['bytes']['total']:,} bytes (16-bit layout estimate), measured error"
          f" {m['build']['hausdorff_m']:.2f} m, plan area {m['plan_area_m2']/1e6:.2f} km2, planes {m['build']['planes_s']:.2f} s")
    print(f"  plan area: buildings {a['buildings']/1e6:.2f} km2, root geometry {a['root_geometry']/1e6:.2f} km2,"
          f" BlockMap cells {a['blockmap_cells']/1e6:.2f} km2; root drops {root['features_dropped']:,} buildings,"
          f" {b['dropped_by_geometry_present']:,} of them in the BlockMap")
    for cam in ("switch", "full", "close", "away"):
        print(f"  {cam:6s} frame ms: root geometry {r['render_root_geometry'][cam]}, BlockMap {r['render'][cam]['frame_ms_median']:.2f}"
              f" ({r['render'][cam]['pixels_covered']:,} px)")
    for lvl, row in r["levels"].items():
        if row["dropped"]:
            print(f"  level {lvl}: {row['dropped']:,} dropped in {row['nodes_dropping']} of {row['nodes']} nodes,"
                  f" {row['dropped_2_texels']} of them >= 2 texels wide")
if docs:
    from PIL import Image, ImageDraw
    work = "out/benchmarks/blockmap-spike-10000"
    frames = json.load(open(f"{work}/root-frames/report.json"))["frames"]
    first_full = next(f["frame"] for f in frames if f["label"] == "full" and f["frame"] % 20 == 0)
    # render --every 20 writes every 20th frame: one of the `full` ones; the BlockMap's own picture of that camera.
    geometry = Image.open(f"{work}/root-frames/frame_{first_full:05d}.png").convert("RGB")
    blockmap = Image.open(f"{work}/blockmap-full.png").convert("RGB")
    w, h = geometry.size
    box = (w // 5, h // 4, w - w // 5, h)
    panels = [geometry.crop(box), blockmap.crop(box)]
    out = Image.new("RGB", (2 * panels[0].width + 8, panels[0].height), "white")
    r0 = result["towns"][0]
    labels = [f"root: geometry + atlases ({r0['root']['bytes'] / 1e6:.2f} MB)",
              f"root: BlockMap ({r0['blockmap']['bytes']['file'] / 1e6:.2f} MB)"]
    for i, (p, label) in enumerate(zip(panels, labels)):
        out.paste(p, (i * (p.width + 8), 0))
        ImageDraw.Draw(out).text((i * (p.width + 8) + 10, 10), label, fill="black")
    out.save("docs/blockmap-spike.png")
    print("wrote docs/blockmap-spike.png")
PY
