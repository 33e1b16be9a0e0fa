#!/usr/bin/env bash
# Benchmark: a sharded build's steps one process at a time, as a cluster runs
# them (issue 17's memory bound): the read and plan (`build --slurm` with a
# stand-in `sbatch` that only prints a job id, so the process ends after the
# plan), every shard (`cityatlas shard PLAN --index K`), then the merge
# (`cityatlas merge PLAN`). Per step: wall and CPU seconds and the peak RSS of
# that one process (os.wait4); the read and the plan apart from the build
# record's per-stage peaks. The output folder is the same as `build`'s.
# Usage: benchmarks/build_steps.sh [BUILDINGS=100000] [D_MIN=default] [TEXTURE_PX=32]
#   D_MIN: metres, or `default` (chosen from the data).
# Writes out/benchmarks/build-steps-<BUILDINGS>-<TEXTURE_PX>-<D_MIN>.json (the
# folder beside it) and prints a table. The town is made once (as build_scale.sh makes it) and not timed.
# CITYATLAS=/path/to/cityatlas runs that executable instead of ./build/cli/cityatlas.
# PAGED_MB=N also runs the read and plan and the merge with
# CITYATLAS_TABLE_MEMORY_MB=N (the per-texture columns paged past N MiB,
# core/paged_column.h; the merge on a hard-linked copy of the same plan and
# shards) and checks that the plan files and the folder are the same.
set -euo pipefail
cd "$(dirname "$0")/.."
N="${1:-100000}"; DMIN="${2:-default}"; PX="${3:-32}"
source benchmarks/synth_town.sh
synth_town "$N" "$PX"
STUB=$(mktemp -d)
trap 'rm -rf "$STUB"' EXIT
printf '#!/bin/sh\necho 1\n' > "$STUB/sbatch"  # the job ids the build prints; nothing is run
chmod +x "$STUB/sbatch"
/usr/bin/python3 - "$TOWN" "$DMIN" "$PX" "$STUB" <<'PY'
import json, os, shutil, subprocess, sys, tempfile, time
town, dmin, px, stub = sys.argv[1:5]
exe = os.environ["CITYATLAS"]
tag = f"{os.path.basename(town)[len('synth-'):]}-{dmin}"
out = f"out/benchmarks/build-steps-{tag}"
for p in (out, out + ".partial", out + ".slurm"):
    shutil.rmtree(p, ignore_errors=True)
plan = out + ".partial/.plan"

def run(name, cmd, env=None):
    with tempfile.TemporaryFile() as err:
        t0 = time.monotonic()
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)  # this child's own usage, not the largest child's so far
        wall = time.monotonic() - t0
        proc.returncode = code = os.waitstatus_to_exitcode(status)
        if code != 0:
            err.seek(0)
            sys.exit(f"{name}: exit {code}: {err.read().decode(errors='replace').strip()[-2000:]}")
    return {"step": name, "wall_s": round(wall, 2), "cpu_s": round(usage.ru_utime + usage.ru_stime, 2),
            "peak_rss_mb": round(usage.ru_maxrss * 1024 / 1e6, 1)}  # MB, as the build record counts

steps = []
env = dict(os.environ, PATH=stub + os.pathsep + os.environ["PATH"])
paged_mb = os.environ.get("PAGED_MB")
paged_env = dict(env, CITYATLAS_TABLE_MEMORY_MB=paged_mb) if paged_mb else None
def build_cmd(o):
    cmd = [exe, "build", os.path.join(town, "town.gml"), "-o", o, "--slurm", "-q"]
    return cmd + (["--d-min", dmin] if dmin != "default" else [])
steps.append(run("read and plan", build_cmd(out), env))
if paged_mb:  # the same plan with paged columns, beside it; compared, then removed
    other = out + "-paged"
    for p in (other + ".partial", other + ".slurm"):
        shutil.rmtree(p, ignore_errors=True)
    steps.append(run(f"read and plan, paged past {paged_mb} MiB", build_cmd(other), paged_env))
    named = {"build.json", "shard.sh", "merge.sh"}  # they name the output folder
    for f in sorted(os.listdir(plan)):
        a, b = os.path.join(plan, f), os.path.join(other + ".partial/.plan", f)
        if f not in named and os.path.isfile(a) and open(a, "rb").read() != open(b, "rb").read():
            sys.exit(f"paged columns change the plan: {f}")
    shutil.rmtree(other + ".partial"), shutil.rmtree(other + ".slurm", ignore_errors=True)
record = json.load(open(os.path.join(plan, "build.json")))
stages = {s[0]: {"wall_s": round(s[1], 2), "cpu_s": round(s[2], 2), "peak_rss_mb": round(s[3], 1)}
          for s in record.get("stages", [])}
shards = len(json.load(open(os.path.join(plan, "plan.json")))["shard_triangles"])
for k in range(shards):
    steps.append(run(f"shard {k}", [exe, "shard", plan, "--index", str(k), "-q"]))
if paged_mb:  # the plan and shards as they are, for a second merge at the same path
    subprocess.run(["cp", "-al", out + ".partial", out + ".snapshot"], check=True)
steps.append(run("merge", [exe, "merge", plan, "-q"]))
if paged_mb:
    os.rename(out, out + ".default")
    os.rename(out + ".snapshot", out + ".partial")
    steps.append(run(f"merge, paged past {paged_mb} MiB", [exe, "merge", plan, "-q"], paged_env))
    same = subprocess.run(["diff", "-r", "-q", "-x", "build_report.json", out + ".default", out],
                          stdout=subprocess.DEVNULL).returncode == 0
    shutil.rmtree(out + ".default")
    if not same:
        sys.exit("paged columns change the merged folder")
report = json.load(open(os.path.join(out, "build_report.json")))
result = {"town": town, "buildings": record.get("features"), "triangles": record.get("triangles"),
          "textures": record.get("textures"), "d_min": dmin, "d_min_used_m": report["d_min"].get("used_m"),
          "shards": shards, "stages_of_read_and_plan": stages, "steps": steps,
          "peak_rss_mb": max(s["peak_rss_mb"] for s in steps), "wall_s": round(sum(s["wall_s"] for s in steps), 1),
          "bytes": report["bytes"], "cityatlas": exe}
path = out + ".json"
json.dump(result, open(path, "w"), indent=1)
shard_steps = [s for s in steps if s["step"].startswith("shard")]
print(f"{result['buildings']} buildings, {result['textures']} textures, {shards} shards, d_min {dmin}"
      f" (used {result['d_min_used_m']:.0f} m)")
for name, s in stages.items():
    print(f"  {name:<16} {s['wall_s']:>9.1f} s {s['cpu_s']:>9.1f} s CPU  peak {s['peak_rss_mb']:>8.1f} MB")
rows = [s for s in steps if not s["step"].startswith("shard")]
if shard_steps:
    worst = max(shard_steps, key=lambda s: s["peak_rss_mb"])
    rows.insert(2 if paged_mb else 1, {"step": f"{len(shard_steps)} shards", "wall_s": sum(s["wall_s"] for s in shard_steps),
                    "cpu_s": sum(s["cpu_s"] for s in shard_steps), "peak_rss_mb": worst["peak_rss_mb"]})
for s in rows:
    print(f"  {s['step']:<28} {s['wall_s']:>9.1f} s {s['cpu_s']:>9.1f} s CPU  peak {s['peak_rss_mb']:>8.1f} MB")
print(f"  every process under {result['peak_rss_mb']:.0f} MB; wrote {path}")
PY
