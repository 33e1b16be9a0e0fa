#!/usr/bin/env bash
# Benchmark: streaming ingest of a ~1 GB synthetic LOD2 CityGML file.
# Usage: benchmarks/ingest_1gb.sh [BUILDINGS=100000]
# Makes the town once (out/benchmarks/town-<N>/, reused), then runs
# `cityatlas ingest --report` (no glb, so nothing holds the whole scene) and
# records wall time, throughput over the file size, and peak RSS measured
# from outside (getrusage of the child) in out/benchmarks/ingest-<N>.json,
# beside the time of a streaming libxml2 parse of the same file
# (`xmllint --stream --noout`, run first, so both read a warm page cache) and
# the ratio of the two (issue 17's yardstick: at most 2.5).
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-100000}"
./scripts/build > /dev/null
mkdir -p out/benchmarks
TOWN="out/benchmarks/town-$N"
if [ ! -f "$TOWN/town.gml" ]; then
  ./build/cli/cityatlas synth --buildings "$N" --lod 2 --seed 1 --texture-size 16 -q --overwrite -o "$TOWN" > /dev/null
fi
/usr/bin/python3 - "$TOWN" "out/benchmarks/ingest-$N.json" <<'PY'
import json, os, resource, subprocess, sys, time
town, result = sys.argv[1:3]
gml = os.path.join(town, "town.gml")
report = result.replace(".json", "-report.json")
def cpu():
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime
t0, c0 = time.monotonic(), cpu()
subprocess.run(["xmllint", "--stream", "--noout", gml], check=True)
xmllint_wall, xmllint_cpu = time.monotonic() - t0, cpu() - c0
cmd = ["./build/cli/cityatlas", "ingest", gml, "-q", "--report", report]
c0 = cpu()
t0 = time.monotonic()
proc = subprocess.run(cmd, capture_output=True, text=True)
wall = time.monotonic() - t0
ingest_cpu = cpu() - c0
if proc.returncode != 0:
    sys.exit(f"ingest failed: {proc.stderr.strip()}")
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
size = os.path.getsize(gml)
r = json.load(open(report))
truth = json.load(open(os.path.join(town, "truth.json")))
rec = {
    "benchmark": "ingest", "command": " ".join(cmd), "file_mb": round(size / 1e6, 1),
    "buildings": r["inputs"][0]["buildings"], "triangles": r["triangles"]["total"],
    "matches_truth": r["triangles"]["total"] == truth["triangles"],
    "wall_s": round(wall, 2), "throughput_mb_s": round(size / 1e6 / wall, 1),
    "peak_rss_mb": round(ru.ru_maxrss / 1024, 1), "limit_mb": 600,
    "cpu_s": round(ingest_cpu, 2), "cores": os.cpu_count(),
    "xmllint_stream_wall_s": round(xmllint_wall, 2), "xmllint_stream_cpu_s": round(xmllint_cpu, 2),
    "ratio_to_xmllint_wall": round(wall / xmllint_wall, 2), "ratio_to_xmllint_cpu": round(ingest_cpu / xmllint_cpu, 2),
}
json.dump(rec, open(result, "w"), indent=2)
print(json.dumps(rec, indent=2))
PY
