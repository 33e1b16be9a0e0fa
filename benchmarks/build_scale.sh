#!/usr/bin/env bash
# Benchmark: `cityatlas build` end to end on a synthetic town (one labelled
# 512 x 512 facade texture per building): time and peak memory per stage,
# output bytes by kind, and the size/accuracy trade of the encoders:
# position bits 11/14/16 (with the per-node error target off, so the bits are
# exactly those) and BC quality fast/best.
# Usage: benchmarks/build_scale.sh [BUILDINGS=10000] [D_MIN=400] [RUNS=all] [TEXTURE_PX=512]
#   RUNS: all, main, bits, bc, charts (default and unique-charts), computed
#   (unique-charts, sky-view, sun-hours: --computed at its defaults), web
#   (default, both: --format both), or a comma list of run names (default,
#   bits11, bits14, bits16, bc-best, unique-charts, sky-view, sun-hours, both).
#   The city-scale runs of issue 17: `10000 400 main` and `100000 2000 main 32`.
# Writes out/benchmarks/build-<BUILDINGS>-<D_MIN>[-<TEXTURE_PX>px].json (one record per run,
# updated after each run; records of runs not repeated are kept) and prints a
# table. Every run rebuilds everything (--force), so each record's
# stage times are complete. The town is made once and not timed.
# CITYATLAS=/path/to/cityatlas runs that executable instead of building and
# running ./build/cli/cityatlas (a long run that the next build must not touch).
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-10000}"; DMIN="${2:-400}"; RUNS="${3:-all}"; PX="${4:-512}"
source benchmarks/synth_town.sh
synth_town "$N" "$PX"
TAG="$N-${DMIN//\//_}"
[ "$PX" = 512 ] || TAG="$TAG-${PX}px"
/usr/bin/python3 - "$TOWN" "$DMIN" "$TAG" "$RUNS" <<'PY'
import json, os, platform, resource, subprocess, sys, time
town, dmin, tag, runs = sys.argv[1:5]
all_variants = [("default", [])]
all_variants += [(f"bits{b}", ["--position-bits", str(b), "--position-error-mm", "0"]) for b in (11, 14, 16)]
all_variants.append(("bc-best", ["--bc-quality", "best"]))
all_variants.append(("unique-charts", ["--unique-charts"]))  # what computed textures need (issue 19)
# Computed textures at their defaults (issue 19), over unique charts: their cost is the wall time over unique-charts'.
all_variants.append(("sky-view", ["--unique-charts", "--computed", "sky_view"]))
all_variants.append(("sun-hours", ["--unique-charts", "--computed", "sun_hours"]))
# The 3D Tiles export beside the native folder (webp, the default): its cost is the wall time over default's.
all_variants.append(("both", ["--format", "both"]))
groups = {"all": [n for n, _ in all_variants if n not in ("sky-view", "sun-hours", "both")], "main": ["default"],
          "bits": ["bits11", "bits14", "bits16"], "bc": ["bc-best"], "charts": ["default", "unique-charts"],
          "computed": ["unique-charts", "sky-view", "sun-hours"], "web": ["default", "both"]}
wanted = groups.get(runs, runs.split(","))
unknown = set(wanted) - {n for n, _ in all_variants}
if unknown: sys.exit(f"unknown runs: {', '.join(sorted(unknown))}")
variants = [v for v in all_variants if v[0] in wanted]
result = f"out/benchmarks/build-{tag}.json"
previous = json.load(open(result))["runs"] if os.path.exists(result) else []
records = []
for name, extra in variants:
    out = f"out/benchmarks/build-{tag}-{name}"
    cmd = [os.environ["CITYATLAS"], "build", os.path.join(town, "town.gml"), "-o", out, "--force", "-q",
           "--d-min", dmin] + extra
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if proc.returncode != 0:
        sys.exit(f"{name}: build failed: {proc.stderr.strip()}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    rep = json.load(open(os.path.join(out, "build_report.json")))
    rec = {"run": name, "command": " ".join(cmd), "wall_s": round(wall, 1),
           "cpu_s": round(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, 1),
           "peak_rss_mb": round(after.ru_maxrss * 1024 / 1e6, 1),  # the largest child so far (Linux: KiB)
           "stages": {s["name"]: round(s["seconds"], 2) for s in rep["stages"]},
           "stage_peak_rss_mb": {s["name"]: round(s["peak_rss_mb"], 1) for s in rep["stages"] if ":" not in s["name"]},
           "bytes": rep["bytes"], "counts": rep["counts"], "errors": rep["errors"], "encoding": rep["encoding"],
           "d_min": rep["d_min"], "root": {"features": rep["root"]["features"], "dropped": len(rep["root"]["features_dropped"])},
           "shards": {k: v for k, v in rep.get("shards", {}).items() if k not in ("keys", "shard_features")}}
    tileset = json.load(open(os.path.join(out, "tileset.json")))
    computed = tileset["extras"]["cityatlas"].get("computed", [])
    if computed:
        rec["computed"] = [{"name": c["name"], "parameters": c["parameters"], "bytes": c["bytes"],
                            "leaf_texels": c["statistics"]["texels"], "mean": c["statistics"]["mean"]} for c in computed]
        base = next((r for r in records + previous if r["run"] == "unique-charts"), None)
        if base:
            rec["computed_seconds"] = round(rec["wall_s"] - base["wall_s"], 1)
            rec["computed_s_per_million_leaf_texels"] = round(rec["computed_seconds"] / (computed[0]["statistics"]["texels"] / 1e6), 2)
        rec["computed_bytes_over_atlas_bytes"] = round(sum(c["bytes"] for c in computed) / rep["bytes"]["atlases"], 3)
    if "tiles3d" in rep:  # --format both: the export's bytes, and its cost over the native build
        t3 = rep["tiles3d"]
        rec["tiles3d"] = {"tiles": t3["tiles"], "bytes": t3["bytes"], "seconds": round(t3["seconds"], 1),
                          "stage_peak_rss_mb": rec["stage_peak_rss_mb"].get("3dtiles")}
        base = next((r for r in records + previous if r["run"] == "default"), None)
        if base: rec["tiles3d"]["wall_over_default_s"] = round(rec["wall_s"] - base["wall_s"], 1)
    records.append(rec)
    kept = [r for r in previous if r["run"] not in {x["run"] for x in records}]
    json.dump({"benchmark": "build", "town": town, "d_min": dmin, "cores": os.cpu_count(), "machine": platform.machine(),
               "runs": kept + records}, open(result, "w"), indent=2)
    top_stages = "  ".join(f"{k} {v:6.1f}" for k, v in rec["stages"].items() if ":" not in k)  # read/atlas/tiles or read/plan/shards/merge
    print(f"{name:8s} wall {rec['wall_s']:7.1f} s  CPU {rec['cpu_s']:7.1f} s ({rec['cpu_s'] / rec['wall_s']:.2f} cores)  {top_stages}  "
          f"shards {rep.get('shards', {}).get('count', 1)}  peak {rec['peak_rss_mb']:7.0f} MB  geometry {rep['bytes']['geometry']/1e6:7.2f} MB  "
          f"atlases {rep['bytes']['atlases']/1e6:8.1f} MB  textures {rep['bytes']['textures']/1e6:7.1f} MB  "
          f"pos err {rep['errors']['position_mm_max']:7.2f} mm  PSNR min/mean {rep['errors']['atlas_psnr_db_min']:.2f}/"
          f"{rep['errors']['atlas_psnr_db_mean']:.2f} dB  BC {rep['encoding']['atlas_mpix_per_s']:.1f} MP/s"
          + (f"  computed {rec['computed'][0]['name']}: {rec['computed'][0]['bytes']/1e6:.2f} MB "
             f"({rec['computed_bytes_over_atlas_bytes']:.3f} of the atlases), {rec['computed'][0]['leaf_texels']/1e6:.2f} M leaf "
             f"texels, +{rec.get('computed_seconds', float('nan'))} s" if computed else "")
          + (f"  3dtiles {(rec['tiles3d']['bytes']['glb'] + rec['tiles3d']['bytes']['shared_images'] + rec['tiles3d']['bytes']['tileset']) / 1e6:.1f} MB in {rec['tiles3d']['seconds']} s "
             f"(+{rec['tiles3d'].get('wall_over_default_s', float('nan'))} s wall)" if "tiles3d" in rec else ""), flush=True)
print(f"written {result}")
PY
