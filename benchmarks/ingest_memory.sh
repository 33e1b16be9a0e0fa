#!/usr/bin/env bash
# Benchmark: what reading holds (issue 17, bounded memory), on the two inputs
# whose readers held a whole file's worth before stop 49:
# - footprints: the synthetic town's footprint shapefile (`synth`, one
#   texture a building), read with `cityatlas ingest F --report` (the scene
#   is not kept: what is measured is the reader);
# - global appearances: Berlin's LOD2 tile from ../shared/data (40 buildings,
#   5,288 texture-coordinate lists in one global appearance, FME ids on every
#   surface data) written COPIES times into one file, ids suffixed per copy,
#   the way a 3DCityDB or FME export of a district holds them;
# - many files: the same footprints cut into TILES files by feature id
#   (ogr2ogr; the town's buildings come row by row, so each file is a stripe
#   of the town), read in one run: what holds per building beyond the reader
#   is the inputs' overlap check (ingest/input_overlap.h, ~150 bytes a
#   building at the read's end until stop 55, now windowed and sorted on disk).
# Usage: benchmarks/ingest_memory.sh [BUILDINGS=100000] [COPIES=100] [TILES=16]
# Writes out/benchmarks/ingest-memory.json (a record per input: peak RSS,
# wall time, buildings, texture-coordinate lists) and prints it. Without
# ../shared/data the Berlin run is skipped (said so).
# CITYATLAS=/path/to/cityatlas runs that executable instead of ./build/cli/cityatlas.
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-100000}"; COPIES="${2:-100}"; TILES="${3:-16}"
if [ -z "${CITYATLAS:-}" ]; then ./scripts/build > /dev/null; fi
export CITYATLAS="${CITYATLAS:-./build/cli/cityatlas}"
mkdir -p out/benchmarks
TOWN="out/benchmarks/synth-$N-32"
if [ ! -f "$TOWN/truth.json" ]; then
  "$CITYATLAS" synth --buildings "$N" --texture-size 32 --lod 2 --seed 1 -q --overwrite -o "$TOWN" > /dev/null
fi
SHARED="${CITYATLAS_SHARED:-../shared}"
/usr/bin/python3 - "$TOWN" "$COPIES" "$SHARED" "$TILES" <<'PY'
import json, os, re, resource, subprocess, sys, tempfile, time
town, copies, shared, tiles = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4])
cityatlas = os.environ["CITYATLAS"]
records = []

def measure(name, paths, **extra):
    paths = paths if isinstance(paths, list) else [paths]
    with tempfile.TemporaryDirectory() as tmp:
        report = os.path.join(tmp, "report.json")
        # A child per run, so that its own peak is RUSAGE_CHILDREN's maximum.
        code = ("import resource, subprocess, sys, time; t = time.time(); "
                "rc = subprocess.call(sys.argv[1:], stdout=subprocess.DEVNULL); "
                "print(rc, time.time() - t, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
        out = subprocess.check_output(["/usr/bin/python3", "-c", code, cityatlas, "ingest", *paths, "--report", report, "-q"])
        rc, wall, kb = out.split()
        if rc != b"0": sys.exit(f"{name}: cityatlas ingest failed ({rc.decode()})")
        r = json.load(open(report))
    rec = {"input": name, "path": paths[0] if len(paths) == 1 else f"{len(paths)} files", "buildings": sum(r["objects_read"].values()) if r["objects_read"] else r["footprints"]["read"],
           "peak_rss_mb": round(int(kb) / 1024, 1), "wall_s": round(float(wall), 2)}
    rec.update(extra)
    records.append(rec)
    print(json.dumps(rec))

measure("footprints", os.path.join(town, "footprints.shp"))
with tempfile.TemporaryDirectory(dir="out/benchmarks") as tmp:
    shp = os.path.join(town, "footprints.shp")
    count = int(re.search(r"Feature Count: (\d+)", subprocess.check_output(["ogrinfo", "-so", "-al", shp], text=True)).group(1))
    parts = []
    for k in range(tiles):
        part = os.path.join(tmp, f"footprints-{k}.shp")
        lo, hi = count * k // tiles, count * (k + 1) // tiles
        subprocess.check_call(["ogr2ogr", "-q", part, shp, "-where", f"FID >= {lo} AND FID < {hi}"])
        parts.append(part)
    measure(f"footprints-in-{tiles}-files", parts)
tile = os.path.join(shared, "data", "citygml1_lod2_berlin_tile_missing_textures", "3890_5819.gml")
if os.path.exists(tile):
    lines = open(tile).read().split("\n")
    # Header, the city object members, the global appearanceMember, the end.
    first = next(i for i, l in enumerate(lines) if "<cityObjectMember>" in l)
    app = next(i for i, l in enumerate(lines) if "<app:appearanceMember>" in l)
    end = next(i for i in range(len(lines) - 1, -1, -1) if "</CityModel>" in lines[i])
    head, members, appearance = "\n".join(lines[:first]), "\n".join(lines[first:app]), "\n".join(lines[app:end])
    ids = re.compile(r"(BLDG_[0-9a-f]+|DEB_LOD[0-9A-Za-z_]*|GEOM_[0-9A-Za-z_]*|UUID_[0-9A-Za-z_-]+|fme-gen-[0-9a-f-]+)")
    with tempfile.TemporaryDirectory(dir="out/benchmarks") as tmp:
        path = os.path.join(tmp, f"berlin-x{copies}.gml")
        with open(path, "w") as f:
            f.write(head + "\n")
            for part in (members, appearance):
                for k in range(copies):
                    f.write(ids.sub(lambda m: m.group(1) + f"k{k}", part) + "\n")
            f.write("</CityModel>\n")
        lists = copies * appearance.count("<app:textureCoordinates")
        measure(f"berlin-tile-x{copies}", path, texture_coordinate_lists=lists)
else:
    print(f"skipped the Berlin run: {tile} is not there (../shared/data)")
json.dump({"benchmark": "ingest-memory", "records": records}, open("out/benchmarks/ingest-memory.json", "w"), indent=1)
print("wrote out/benchmarks/ingest-memory.json")
PY
