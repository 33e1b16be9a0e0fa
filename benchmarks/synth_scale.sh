#!/usr/bin/env bash
# Benchmark: time and peak memory of `cityatlas synth` for a large town.
# Usage: benchmarks/synth_scale.sh [BUILDINGS=10000] [TEXTURE_SIZE=512]
# Writes out/benchmarks/synth-<BUILDINGS>-<SIZE>.json and prints it. Wall time
# and peak RSS are measured from outside the process (getrusage of the child).
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-10000}"; S="${2:-512}"
./scripts/build > /dev/null
mkdir -p out/benchmarks
OUT="out/benchmarks/synth-$N-$S"
RESULT="out/benchmarks/synth-$N-$S.json"
/usr/bin/python3 - "$N" "$S" "$OUT" "$RESULT" <<'PY'
import json, os, platform, resource, subprocess, sys, time
n, s, out, result = sys.argv[1:5]
cmd = ["./build/cli/cityatlas", "synth", "--buildings", n, "--texture-size", s, "--lod", "2", "--seed", "1",
       "-q", "--overwrite", "-o", out]
t0 = time.monotonic()
proc = subprocess.run(cmd, capture_output=True, text=True)
wall = time.monotonic() - t0
if proc.returncode != 0:
    sys.exit(f"synth failed: {proc.stderr.strip()}")
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(out) for f in fs)
truth = json.load(open(os.path.join(out, "truth.json")))
rec = {
    "benchmark": "synth", "command": " ".join(cmd), "buildings": int(n), "texture_size_px": int(s),
    "wall_s": round(wall, 2), "user_s": round(ru.ru_utime, 2), "system_s": round(ru.ru_stime, 2),
    "peak_rss_mb": round(ru.ru_maxrss / 1024, 1), "output_mb": round(size / 1e6, 1),
    "gml_mb": round(os.path.getsize(os.path.join(out, "town.gml")) / 1e6, 1),
    "textures": truth["textures"]["count"], "triangles": truth["triangles"], "cores": os.cpu_count(),
    "machine": platform.machine(),
}
json.dump(rec, open(result, "w"), indent=2)
print(json.dumps(rec, indent=2))
PY
