#!/usr/bin/env python3
# The driver behind benchmarks/trade.sh (see there for what it measures).
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

CITYATLAS = "./build/cli/cityatlas"
IMAGE_COMPARE = "./build/tests/tools/image_compare"
CLEAR = "196,218,243"  # the renderer's clear colour as sRGB bytes (tests/cli/render_cli.sh)
SIZE, FPS = "480x270", "1"
OUT = "out/benchmarks"
WORK = os.path.join(OUT, "trade")

args = [a for a in sys.argv[1:] if not a.startswith("--")]
docs = "--docs" in sys.argv[1:]
which = args[0] if args else "all"


def run(cmd):
    """Runs cmd; returns (wall seconds, the child's own peak RSS in MB)."""
    t0 = time.monotonic()
    with tempfile.TemporaryFile(mode="w+") as err:  # a file, not a pipe: wait4 cannot deadlock on it
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.monotonic() - t0
        code = os.waitstatus_to_exitcode(status)
        if code != 0:
            err.seek(0)
            sys.exit(f"{' '.join(cmd)}: exit {code}: {err.read().strip()[-2000:]}")
    return wall, usage.ru_maxrss * 1024 / 1e6  # Linux: KiB


def datasets():
    d = []
    if which in ("all", "town"):
        town = os.path.join(OUT, "synth-200-512")
        if not os.path.exists(os.path.join(town, "truth.json")):
            subprocess.run([CITYATLAS, "synth", "--buildings", "200", "--seed", "1", "-q", "--overwrite", "-o", town],
                           check=True, capture_output=True)
        d.append(("town200", os.path.join(town, "town.gml")))
    berlin = "../shared/data/citygml2_textured_berlin_vcs_export"
    if which in ("all", "berlin"):
        if os.path.isdir(berlin):
            d.append(("berlin", berlin))
        else:
            print(f"trade.sh: {berlin} is absent (the team's shared data): the real dataset is skipped", file=sys.stderr)
    return d


def build(name, source, extra):
    out = os.path.join(WORK, name)
    wall, peak = run([CITYATLAS, "build", source, "-o", out, "--force", "-q"] + extra)
    r = json.load(open(os.path.join(out, "build_report.json")))
    b = r["bytes"]
    return out, {"build_s": round(wall, 2), "peak_rss_mb": round(peak, 1), "d_min_m": r["d_min"]["used_m"],
                 "bytes": {k: b[k] for k in ("geometry", "atlases", "textures", "features", "total")},
                 "texture_ratio": round(r["texture_economy"]["ratio"], 4), "nodes": r["counts"]["nodes"],
                 "position_mm_max": r["errors"]["position_mm_max"], "atlas_psnr_db_min": r["errors"]["atlas_psnr_db_min"],
                 "candidates": r["d_min"]["candidates"]}


def render(folder, frames_dir, extra):
    shutil.rmtree(frames_dir, ignore_errors=True)
    wall, _ = run([CITYATLAS, "render", folder, "--size", SIZE, "--fps", FPS, "--wait", "--anisotropy", "1",
                   "--budget", "8G", "-o", frames_dir, "-q"] + extra)
    s = json.load(open(os.path.join(frames_dir, "report.json")))["summary"]
    return {"render_s": round(wall, 1), "frames": s["frames"], "nodes_drawn_mean": round(s["nodes_drawn_mean"], 1),
            "nodes_drawn_max": s["nodes_drawn_max"], "texture_binds_mean": round(s["texture_binds_mean"], 1),
            "bytes_loaded": s["bytes_loaded"], "frame_ms_median": round(s["frame_ms_median"], 1)}


def psnr(frames_dir, reference_dir):
    values = []
    for f in sorted(os.listdir(reference_dir)):
        if not f.endswith(".png"):
            continue
        p = subprocess.run([IMAGE_COMPARE, os.path.join(frames_dir, f), os.path.join(reference_dir, f), CLEAR],
                           capture_output=True, text=True, check=True)
        r = json.loads(p.stdout)
        if r["reference_covered"] > 1000:  # frames that show the city
            values.append(r["psnr_db"])
    return {"psnr_db_min": round(min(values), 2), "psnr_db_mean": round(sum(values) / len(values), 2),
            "psnr_frames": len(values)}


def reference(name, source, slug, extra):
    """The original-texture rendering of the same data and parameters: built with
    --originals all (no atlas changes), drawn with --mode original."""
    folder, _ = build(f"{name}-{slug}-reference", source, extra + ["--originals", "all"])
    frames = os.path.join(WORK, f"{name}-{slug}-reference-frames")
    render(folder, frames, ["--mode", "original"])
    shutil.rmtree(folder, ignore_errors=True)
    return frames


def measure(name, source):
    print(f"== {name}", flush=True)
    runs = []
    out, default = build(f"{name}-default", source, [])
    ref_frames = reference(name, source, "default", [])
    d = default["d_min_m"]
    variants = [("default", [], "default")]
    variants += [(f"d_min x{k:g}", ["--d-min", f"{d * k:.3f}"], "d_min") for k in (0.25, 0.5, 2, 4)]
    variants += [(f"atlas {a}", ["--atlas-size", str(a)], "atlas size") for a in (256, 1024)]
    variants += [("bc best", ["--bc-quality", "best"], "bc quality")]
    variants += [(f"bits {b}", ["--position-bits", str(b), "--position-error-mm", "0"], "position bits") for b in (11, 16)]
    for label, extra, knob in variants:
        slug = label.replace(" ", "-")
        folder, rec = (out, default) if label == "default" else build(f"{name}-{slug}", source, extra)
        frames = os.path.join(WORK, f"{name}-{slug}-frames")
        rec = dict(rec, run=label, knob=knob, args=" ".join(extra))
        rec.update(render(folder, frames, []))
        rec.update(psnr(frames, ref_frames if label == "default" else reference(name, source, slug, extra)))
        if label != "default":
            rec.pop("candidates")
        runs.append(rec)
        print(f"  {label:14s} build {rec['build_s']:6.1f} s  peak {rec['peak_rss_mb']:6.0f} MB  textures "
              f"{(rec['bytes']['atlases'] + rec['bytes']['textures']) / 1e6:8.2f} MB  R {rec['texture_ratio']:5.2f}  "
              f"PSNR {rec['psnr_db_mean']:5.2f} (min {rec['psnr_db_min']:5.2f}) dB  nodes {rec['nodes_drawn_mean']:6.1f}",
              flush=True)
        if label != "default" and knob != "d_min":
            shutil.rmtree(folder, ignore_errors=True)
    for tau in (0.5, 2, 4):
        frames = os.path.join(WORK, f"{name}-tau{tau:g}-frames")
        rec = dict({k: v for k, v in default.items() if k != "candidates"}, run=f"tau {tau:g}", knob="tau", args=f"render --tau {tau:g}")
        rec.update(render(out, frames, ["--tau", f"{tau:g}"]))
        rec.update(psnr(frames, ref_frames))
        runs.append(rec)
        print(f"  {rec['run']:14s} PSNR {rec['psnr_db_mean']:5.2f} (min {rec['psnr_db_min']:5.2f}) dB  nodes "
              f"{rec['nodes_drawn_mean']:6.1f}  loaded {rec['bytes_loaded'] / 1e6:7.1f} MB", flush=True)
    return {"dataset": name, "source": source, "runs": runs}


def plots(results):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    colours = {"town200": "tab:blue", "berlin": "tab:orange"}
    written = []

    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(11.0, 3.3), dpi=90)
    for res in results:
        c = colours.get(res["dataset"], "k")
        default = next(r for r in res["runs"] if r["run"] == "default")
        est = default["candidates"]
        ax1.plot([e["d_m"] for e in est], [e["ratio"] for e in est], ":", color=c, label=f"{res['dataset']} estimate")
        pts = sorted((r for r in res["runs"] if r["knob"] in ("d_min", "default")), key=lambda r: r["d_min_m"])
        ax1.plot([r["d_min_m"] for r in pts], [r["texture_ratio"] for r in pts], "o-", color=c, label=f"{res['dataset']} built")
        ax1.plot([default["d_min_m"]], [default["texture_ratio"]], "*", color=c, markersize=14)
        ax2.plot([r["d_min_m"] for r in pts], [r["psnr_db_mean"] for r in pts], "o-", color=c, label=f"{res['dataset']} mean")
        ax2.plot([r["d_min_m"] for r in pts], [r["psnr_db_min"] for r in pts], "v--", color=c, label=f"{res['dataset']} worst frame")
        ax3.plot([r["d_min_m"] for r in pts], [r["bytes_loaded"] / 1e6 for r in pts], "o-", color=c, label=f"{res['dataset']} MB loaded")
        ax3.plot([r["d_min_m"] for r in pts], [r["texture_binds_mean"] for r in pts], "s--", color=c, label=f"{res['dataset']} binds / frame")
        ax3.plot([e["d_m"] for e in est], [max(e["originals_within_d_min_mb"], 1e-3) for e in est], ":", color=c,
                 label=f"{res['dataset']} est. originals within d_min (MB)")
    ax1.set(xscale="log", yscale="log", xlabel="d_min (m)", ylabel="(atlases + originals) / originals",
            title="Storage: textures over the data's (* = default)")
    ax1.axhline(2.0, color="grey", linewidth=0.8)
    ax2.set(xscale="log", xlabel="d_min (m)", ylabel="PSNR vs originals (dB; 99 = identical)",
            title="Atlas tree vs originals, default path")
    ax3.set(xscale="log", yscale="log", xlabel="d_min (m)", title="Client load (the chooser limits 64 MB)", ylim=(0.5, None))
    ax3.axhline(64, color="grey", linewidth=0.8)
    for ax in (ax1, ax2, ax3):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    written.append(os.path.join(OUT, "trade-dmin.png"))
    fig.savefig(written[-1])

    fig, ax = plt.subplots(figsize=(8.4, 3.6), dpi=90)
    for res in results:
        c = colours.get(res["dataset"], "k")
        for r in res["runs"]:
            if r["knob"] == "tau":
                continue
            x = (r["bytes"]["atlases"] + r["bytes"]["textures"]) / 1e6
            ax.plot([x], [r["psnr_db_mean"]], "o" if r["run"] == "default" else ".", color=c,
                    markersize=10 if r["run"] == "default" else 7)
            ax.annotate(r["run"], (x, r["psnr_db_mean"]), fontsize=6, xytext=(3, 2), textcoords="offset points")
    ax.set(xscale="log", xlabel="texture bytes in the folder (MB)", ylabel="mean PSNR vs originals (dB)",
           title="One knob at a time: texture bytes against image error (big dot: default; blue: town, orange: Berlin)",
           )
    ax.title.set_fontsize(9)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    written.append(os.path.join(OUT, "trade-size-error.png"))
    fig.savefig(written[-1])

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(8.4, 3.0), dpi=90)
    for res in results:
        c = colours.get(res["dataset"], "k")
        pts = sorted((r for r in res["runs"] if r["knob"] in ("tau", "default")),
                     key=lambda r: float(r["args"].split()[-1]) if r["knob"] == "tau" else 1.0)
        taus = [float(r["args"].split()[-1]) if r["knob"] == "tau" else 1.0 for r in pts]
        ax1.plot(taus, [r["nodes_drawn_mean"] for r in pts], "o-", color=c, label=res["dataset"])
        ax2.plot(taus, [r["psnr_db_mean"] for r in pts], "o-", color=c, label=res["dataset"])
    ax1.set(xscale="log", xlabel="render --tau (pixels per texel)", ylabel="nodes drawn (mean)", title="What tau buys")
    ax2.set(xscale="log", xlabel="render --tau", ylabel="mean PSNR vs originals (dB)", title="What it costs")
    for ax in (ax1, ax2):
        ax.set_xticks([0.5, 1, 2, 4], ["0.5", "1", "2", "4"])
        ax.minorticks_off()
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    written.append(os.path.join(OUT, "trade-tau.png"))
    fig.savefig(written[-1])
    return written


def main():
    os.makedirs(WORK, exist_ok=True)
    if "--plot-only" in sys.argv[1:]:  # redraw from the last run's table
        results = json.load(open(os.path.join(OUT, "trade.json")))["datasets"]
    else:
        results = [measure(n, s) for n, s in datasets()]
    if not results:
        sys.exit("trade.sh: no dataset to measure")
    json.dump({"benchmark": "trade", "size": SIZE, "fps": FPS, "cores": os.cpu_count(), "datasets": results},
              open(os.path.join(OUT, "trade.json"), "w"), indent=1)
    for png in plots(results):
        print(f"written {png}")
        if docs:
            os.makedirs("docs", exist_ok=True)
            shutil.copy(png, os.path.join("docs", os.path.basename(png)))
    print(f"written {os.path.join(OUT, 'trade.json')}")


main()
