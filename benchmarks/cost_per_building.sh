#!/usr/bin/env bash
# Benchmark: what one building costs `build` as the city grows (issue 17's
# "cost per building flat from 10k to 1M"): benchmarks/build_scale.sh's main
# run for each size (synthetic LOD2 towns, 32 px facades, one --d-min for
# all, so the trees differ only by the city's size), then wall seconds, CPU
# seconds, peak RSS and output bytes per building against the size, as
# out/benchmarks/cost_per_building.json and .png (log x axis).
# Usage: [REUSE=1] benchmarks/cost_per_building.sh [SIZES="10000 25000 50000 100000 1000000"] [D_MIN=2000]
# Installs Debian's python3-matplotlib when it is missing (for the plot).
set -euo pipefail
cd "$(dirname "$0")/.."
SIZES="${1:-10000 25000 50000 100000 1000000}"; DMIN="${2:-2000}"
# REUSE=1: sizes already measured (out/benchmarks/build-N-D_MIN-32px.json) are not run again.
for n in $SIZES; do
  if [ "${REUSE:-0}" = 1 ] && [ -f "out/benchmarks/build-$n-$DMIN-32px.json" ]; then continue; fi
  benchmarks/build_scale.sh "$n" "$DMIN" main 32
done
if ! /usr/bin/python3 -c "import matplotlib" 2> /dev/null; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends python3-matplotlib > /dev/null
fi
/usr/bin/python3 - "$DMIN" $SIZES <<'PY'
import json, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
dmin, sizes = sys.argv[1], [int(s) for s in sys.argv[2:]]
rows = []
for n in sizes:
    run = next(r for r in json.load(open(f"out/benchmarks/build-{n}-{dmin}-32px.json"))["runs"] if r["run"] == "default")
    total = run["bytes"]["total"]
    rows.append({"buildings": n, "triangles": run["counts"]["triangles"], "wall_s": run["wall_s"], "cpu_s": run["cpu_s"],
                 "peak_rss_mb": run["peak_rss_mb"], "output_bytes": total,
                 "wall_ms_per_building": 1e3 * run["wall_s"] / n, "cpu_ms_per_building": 1e3 * run["cpu_s"] / n,
                 "rss_kb_per_building": 1e3 * run["peak_rss_mb"] / n, "output_kb_per_building": total / 1e3 / n,
                 "stages": run["stages"]})
json.dump({"benchmark": "cost_per_building", "d_min_m": float(dmin), "texture_px": 32, "runs": rows},
          open("out/benchmarks/cost_per_building.json", "w"), indent=2)
fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
for ax, key, label in zip(axes, ["wall_ms_per_building", "rss_kb_per_building", "output_kb_per_building"],
                          ["wall ms / building (CPU dashed)", "peak RSS kB / building", "output kB / building"]):
    ax.plot(sizes, [r[key] for r in rows], "o-")
    if key == "wall_ms_per_building":
        ax.plot(sizes, [r["cpu_ms_per_building"] for r in rows], "o--")
    ax.set_xscale("log"); ax.set_xlabel("buildings"); ax.set_title(label); ax.set_ylim(bottom=0); ax.grid(alpha=0.3)
fig.suptitle(f"cityatlas build, synthetic LOD2 towns, 32 px facades, --d-min {dmin}")
fig.tight_layout(); fig.savefig("out/benchmarks/cost_per_building.png", dpi=90)
print(f"{'buildings':>10} {'wall s':>8} {'ms/bldg':>8} {'CPU ms':>8} {'RSS MB':>8} {'kB/bldg':>8} {'out kB':>8}")
for r in rows:
    print(f"{r['buildings']:>10} {r['wall_s']:8.1f} {r['wall_ms_per_building']:8.2f} {r['cpu_ms_per_building']:8.2f} "
          f"{r['peak_rss_mb']:8.0f} {r['rss_kb_per_building']:8.1f} {r['output_kb_per_building']:8.1f}")
print("written out/benchmarks/cost_per_building.json and .png")
PY
