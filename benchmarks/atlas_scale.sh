#!/usr/bin/env bash
# Benchmark: time and peak memory of `cityatlas atlas` (the texture-atlas tree)
# on a synthetic town with unique facade textures (the papers' Berlin set-up:
# one labelled 512 x 512 texture per building, repeated around its walls).
# Usage: benchmarks/atlas_scale.sh [BUILDINGS=10000] [D_MIN=400] [TEXTURE_SIZE=512] [extra atlas options...]
#   D_MIN: metres, or D/N (a fraction of the scene diagonal, as the papers give it).
# Writes out/benchmarks/atlas-<BUILDINGS>-<D_MIN>.json and prints it. The town
# is made once (out/benchmarks/synth-<BUILDINGS>-<SIZE>, shared with
# synth_scale.sh) and not timed. Wall time and peak RSS are measured from
# outside the process (getrusage of the child).
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-10000}"; DMIN="${2:-400}"; S="${3:-512}"; shift $(( $# < 3 ? $# : 3 ))
./scripts/build > /dev/null
mkdir -p out/benchmarks
TOWN="out/benchmarks/synth-$N-$S"
if [ ! -f "$TOWN/truth.json" ]; then
  ./build/cli/cityatlas synth --buildings "$N" --texture-size "$S" --lod 2 --seed 1 -q --overwrite -o "$TOWN" > /dev/null
fi
TAG="$N-${DMIN//\//_}"
OUT="out/benchmarks/atlas-$TAG"
RESULT="out/benchmarks/atlas-$TAG.json"
/usr/bin/python3 - "$TOWN" "$DMIN" "$OUT" "$RESULT" "$N" "$S" "$@" <<'PY'
import json, os, platform, resource, subprocess, sys, time
town, dmin, out, result, n, s = sys.argv[1:7]
extra = sys.argv[7:]
cmd = ["./build/cli/cityatlas", "atlas", os.path.join(town, "town.gml"), "-o", out, "--overwrite", "-q",
       "--d-min", dmin] + extra
t0 = time.monotonic()
proc = subprocess.run(cmd, capture_output=True, text=True)
wall = time.monotonic() - t0
if proc.returncode != 0:
    sys.exit(f"atlas failed: {proc.stderr.strip()}")
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
rep = json.load(open(os.path.join(out, "atlas_report.json")))
truth = json.load(open(os.path.join(town, "truth.json")))
size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(out) for f in fs)
# As the thesis counts it (7.32 GB for Berlin's 10,000 facades): RGB texels, in GiB.
facade_gib = truth["textures"]["facade"] * int(s) * int(s) * 3 / 2**30
rec = {
    "benchmark": "atlas", "command": " ".join(cmd), "buildings": int(n), "texture_size_px": int(s),
    "wall_s": round(wall, 2), "user_s": round(ru.ru_utime, 2), "system_s": round(ru.ru_stime, 2),
    "peak_rss_mb": round(ru.ru_maxrss * 1024 / 1e6, 1), "output_mb": round(size / 1e6, 1),  # Linux: KiB
    "facade_texels_gib_uncompressed": round(facade_gib, 2), "triangles": rep["scene"]["triangles"], "textures": rep["scene"]["textures"],
    "original_texture_mb": round(rep["texels"]["original_texture_bytes"] / 1e6, 1),
    "atlas_texture_mb_uncompressed": round(rep["texels"]["atlas_texture_bytes"] / 1e6, 1),
    "d_min": rep["d_min"], "critical_triangles": rep["critical_triangles"],
    "nodes": rep["tree"]["nodes"], "leaves": rep["tree"]["leaves"], "depth": rep["tree"]["depth"],
    "atlases": rep["tree"]["atlases"], "coverage": rep["tree"]["coverage"],
    "steps": rep["steps"], "cores": os.cpu_count(), "machine": platform.machine(),
}
json.dump(rec, open(result, "w"), indent=2)
print(json.dumps(rec, indent=2))
PY
