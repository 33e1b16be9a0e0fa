// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas atlas`: city data -> texture-atlas tree (atlas images + report).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "atlas/atlas_report.h"
#include "atlas/atlas_tree.h"
#include "cli/atlas_options.h"
#include "cli/commands.h"
#include "cli/outcome.h"
#include "cli/progress.h"
#include "core/resource_usage.h"
#include "cli/scene_input.h"

namespace cityatlas::cli {
namespace fs = std::filesystem;
namespace {

struct AtlasCliOptions {
    SceneInputOptions input;
    std::string output;
    AtlasTreeOptions tree;
    bool overwrite = false;
    bool quiet = false;
};

}  // namespace

std::string dMinSentence(const atlas::AtlasStats& s) {
    std::string out = fmt::format("d_min {:.1f} m", s.d_min_used_m);
    if (s.d_min_used_m > s.d_min_requested_m)
        out += fmt::format(", enlarged from {:.1f} m for critical triangles", s.d_min_requested_m);
    if (s.d_min_choice.rule == "data") out += fmt::format(" (chosen from the data: {}; --d-min sets it)", s.d_min_choice.reason);
    else if (s.d_min_choice.rule == "diagonal-fraction") out += fmt::format(" ({})", s.d_min_choice.reason);
    return out + fmt::format("; scene diagonal {:.1f} m", s.scene_diagonal_m);
}

std::string textureEconomySentence(const atlas::AtlasStats& s) {
    const uint64_t used = s.textures_exact + s.textures_needing_originals;
    return fmt::format("textures: {} of {} held at full resolution by the atlases (no original needed), {} capped at "
                       "their own resolution; atlases + originals needed = {:.2f}x the originals as BC with mips",
                       s.textures_exact, used, s.textures_upsampled, s.bytes.ratio());
}

Status parseAtlasTreeOptions(const AtlasTreeOptions& opt, atlas::AtlasParams* p) {
    *p = opt.params;
    const std::string& d = opt.d_min;
    char* end = nullptr;
    if (d == "auto") {
        p->d_min_m.reset();
        p->d_min_from_data = true;
    } else if (d.rfind("D/", 0) == 0) {
        const double n = std::strtod(d.c_str() + 2, &end);
        if (*end || !(n >= 1)) return Status::Usage(fmt::format("--d-min {}: expected auto, metres or D/N with N >= 1", d));
        p->d_min_m.reset();
        p->d_min_from_data = false;
        p->d_min_diagonal_fraction = 1.0 / n;
    } else {
        const double m = std::strtod(d.c_str(), &end);
        if (*end || end == d.c_str() || !(m > 0))
            return Status::Usage(fmt::format("--d-min {}: expected auto, metres or D/N", d));
        p->d_min_m = m;
    }
    int w = 0, h = 0;
    if (std::sscanf(opt.screen.c_str(), "%dx%d", &w, &h) != 2 || w < 1 || h < 1)
        return Status::Usage(fmt::format("--screen {}: expected WIDTHxHEIGHT in pixels", opt.screen));
    p->screen_width_px = w, p->screen_height_px = h;
    const auto f = atlas::filterFromName(opt.filter);
    if (!f) return Status::Usage(fmt::format("--filter {}: expected box, triangle, mitchell or lanczos3", opt.filter));
    p->filter = *f;
    const auto m = atlas::packingMethodFromName(opt.packing);
    if (!m) return Status::Usage(fmt::format("--packing {}: expected maxrects or igarashi-cosgrove", opt.packing));
    p->packing = *m;
    p->critical_fraction = opt.critical_percent / 100.0;
    return atlas::validateParams(*p);
}

namespace {

int fail(Progress& progress, const Status& s) { return cli::fail("atlas", s, &progress); }

int runAtlas(const AtlasCliOptions& opt) {
    atlas::AtlasParams params;
    if (Status s = parseAtlasTreeOptions(opt.tree, &params); !s.ok()) return cli::fail("atlas", s);
    const fs::path target = fs::path(opt.output).lexically_normal();
    std::error_code ec;
    if (target.empty() || target == "." || target == "/")
        return cli::fail("atlas", Status::Io(fmt::format("{}: refusing to use this as the output folder", opt.output)));
    if (Status s = recoverInterruptedOutput(target); !s.ok()) return cli::fail("atlas", s);
    if (fs::exists(target, ec) && !opt.overwrite)
        return cli::fail("atlas", Status::Io(fmt::format("{}: already exists (use --overwrite to replace it)",
                                                            target.string())));

    Progress progress(!opt.quiet);
    const auto t_start = std::chrono::steady_clock::now();
    StageClock read_clock;
    IngestState state;
    SceneCollector collector;
    state.sink = &collector;
    std::vector<fs::path> files;
    if (Status s = readInputs(opt.input, progress, state, &files); !s.ok()) return fail(progress, s);
    Scene& scene = collector.scene;
    attachGeoreference(state, computeStats(scene).bounds_local, scene.georef, files.front());
    const StageCost read = read_clock.lap();

    // Everything goes to a sibling working folder renamed into place at the
    // end: a failed or interrupted run never leaves a half-written tree.
    fs::path tmp;
    if (const Status st = startWorkingFolder(target, {}, &tmp); !st.ok()) return fail(progress, st);
    auto abandon = [&](const Status& s) {
        std::error_code ignored;
        fs::remove_all(tmp, ignored);
        return fail(progress, s);
    };

    atlas::AtlasTree tree;
    Diagnostics& diagnostics = state.diagnostics;
    const Status built = atlas::buildAtlasTree(
        scene, params, tmp, diagnostics,
        [&](const char* step, uint64_t done, uint64_t total) { progress.update(step, done, total); }, &tree);
    if (!built.ok()) return abandon(built);
    tree.stats.steps.insert(tree.stats.steps.begin(), {"read", read.seconds, read.peak_rss_mb, read.cpu_seconds});
    const auto report = atlas::makeAtlasReport(tree, scene, diagnostics);
    if (Status s = writeTextAtomically(tmp / "atlas_report.json", report.dump(2) + "\n"); !s.ok())
        return abandon(s);
    if (Status s = replaceFolder(tmp, target); !s.ok()) return abandon(s);
    progress.finish();

    const atlas::AtlasStats& s = tree.stats;
    std::printf("Atlas tree: %llu nodes (%llu leaves), depth %d, %llu atlases of at most %d x %d\n",
                static_cast<unsigned long long>(s.nodes), static_cast<unsigned long long>(s.leaves), s.depth,
                static_cast<unsigned long long>(s.atlases), params.atlas_size_px, params.atlas_size_px);
    std::printf("  %s\n", dMinSentence(s).c_str());
    std::printf("  critical triangles: %llu at the requested d_min, %llu split into %llu more\n",
                static_cast<unsigned long long>(s.critical_triangles),
                static_cast<unsigned long long>(s.triangles_split),
                static_cast<unsigned long long>(s.triangles_added_by_split));
    std::printf("  leaf coverage %.1f %%; texels: originals %s, atlases %s (uncompressed)\n",
                s.leaf_atlas_texels ? 100.0 * static_cast<double>(s.packed_texels) / s.leaf_atlas_texels : 0.0,
                humanBytes(s.original_texture_bytes).c_str(), humanBytes(s.atlas_texture_bytes).c_str());
    std::printf("  %s\n", textureEconomySentence(s).c_str());
    printWarnings(diagnostics);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    std::printf("Output: %s (report: atlas_report.json)\nTime %.2f s, peak memory %s\n", target.string().c_str(),
                seconds, humanBytes(peakRssBytes()).c_str());
    return kExitOk;
}

}  // namespace

void addAtlasTreeOptions(CLI::App* cmd, AtlasTreeOptions* opt) {
    auto* g = "Atlas tree";
    cmd->add_option("--d-min", opt->d_min,
                    "Minimum camera distance for leaf atlases: auto (chosen from the data: the smallest distance at "
                    "which atlases plus the originals still needed are estimated at <= 1.8x the original textures as "
                    "BC, with <= 64 MB of originals within d_min of any camera; printed with the reason), metres, or "
                    "D/N for the scene's bounding-box diagonal divided by N (the papers use D/72). Nearer than this, "
                    "leaves draw the originals of textures their atlas holds below full resolution. No atlas holds a "
                    "texture above its own resolution, so a small d_min costs at most the originals' texels once per "
                    "repeat; atlas texels grow as 1/d_min^2 until then. d_min grows by itself when too many "
                    "triangles are critical (see the report)")
        ->default_val("auto")
        ->group(g);
    cmd->add_option("--atlas-size", opt->params.atlas_size_px, "Atlas size A in texels: a power of two, 64..4096")
        ->default_val(512)
        ->group(g);
    cmd->add_option("--border", opt->params.border_px,
                    "Border of real texture content around each packed region, texels; at most a quarter of a "
                    "region's content (regions are rounded up to 4x4 S3TC blocks)")
        ->default_val(8)
        ->group(g);
    cmd->add_option("--screen", opt->screen, "Assumed viewport, WIDTHxHEIGHT pixels")->default_val("1920x1080")->group(g);
    cmd->add_option("--fov", opt->params.vertical_fov_deg, "Assumed vertical field of view, degrees")
        ->default_val(60)
        ->group(g);
    cmd->add_option("--filter", opt->filter,
                    "Resampling kernel for leaf atlases, in linear light: box, triangle, mitchell, lanczos3")
        ->default_val("lanczos3")
        ->group(g);
    cmd->add_option("--packing", opt->packing,
                    "Packing heuristic: maxrects (best short side fit) or igarashi-cosgrove (the papers')")
        ->default_val("maxrects")
        ->group(g);
    cmd->add_flag("--unique-charts", opt->params.unique_charts,
                  "No two world-distinct triangles share atlas texels: triangles that reuse one part of a texture "
                  "(walls mapping one photo 0..1) each get their own region (what a computed texture needs; costs "
                  "the duplicated regions' texels)")
        ->group(g);
    cmd->add_option("--critical-percent", opt->critical_percent,
                    "If more textured triangles than this are critical (too large for one atlas), d_min is enlarged "
                    "until this many are; the rest are split (and d_min grows further if splitting would add more "
                    "triangles than the scene has textured ones, or 10,000)")
        ->default_val(10)
        ->check(CLI::Range(0.0, 100.0))
        ->group(g);
    cmd->add_option("--threads", opt->params.threads, "Worker threads (0 = all cores); the output does not depend on it")
        ->default_val(0)
        ->group(g);
    cmd->add_option("--cache-mb", opt->params.cache_mb, "Memory for decoded original textures, kept for the leaves that share them, MB")
        ->default_val(256)
        ->group(g);
    cmd->add_option_function<uint64_t>(
           "--models-mb", [opt](uint64_t mb) { opt->params.model_budget_bytes = mb << 20; },
           "Memory for the scene-wide texture models that choose d_min and the promotions (48 bytes a textured "
           "triangle, as allocated, and 128 a texture), MB; a city whose models need more is planned a range of textures at a time, a pass over "
           "its triangles each. The output does not depend on it")
        ->default_val(256)
        ->check(CLI::Range(uint64_t{1}, uint64_t{1} << 20))
        ->group(g);
}

RunFn addAtlasCommand(CLI::App& app) {
    auto opt = std::make_shared<AtlasCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "atlas",
        "Build the multiresolution texture-atlas tree (Buchholz & Doellner 2005) of city data: nodes split until\n"
        "each node's textures, at the resolution a camera d_min away can resolve but never above their own, pack\n"
        "into one A x A atlas; every atlas is only as large as its content; inner atlases are their children halved.\n"
        "Writes atlas/<opaque|alpha>/<node>.png (8-bit sRGB) and atlas_report.json (schema:\n"
        "schemas/atlas_report.schema.json, with the texel budget and how d_min was chosen) into a new folder,\n"
        "atomically. Guarantee: from at least a node's min_distance_m, no atlas texel covers more than one pixel\n"
        "anywhere on the assumed screen (frustum corners included), or it is a texel of the texture itself.");
    addSceneInputOptions(cmd, &opt->input);
    cmd->add_option("-o,--output", opt->output, "Output folder (created; must not exist unless --overwrite)")->required();
    cmd->add_flag("--overwrite", opt->overwrite, "Replace an existing output folder");
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
    addAtlasTreeOptions(cmd, &opt->tree);
    return [opt]() { return runAtlas(*opt); };
}

}  // namespace cityatlas::cli
