// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas inspect`: checks a tile folder and summarises its tree.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "cli/commands.h"
#include "cli/outcome.h"
#include "cli/progress.h"
#include "tiles/inspect.h"

namespace cityatlas::cli {
namespace {
namespace fs = std::filesystem;

struct InspectCliOptions {
    std::string folder;
    int threads = 0;
    bool quiet = false;
};

void printSummary(const std::string& folder, const tiles::InspectResult& r, double seconds) {
    fmt::print("{}: {} nodes, {} leaves, {} levels, {} triangles (checked in {:.2f} s)\n", folder, r.nodes, r.leaves,
               r.levels.size(), r.triangles, seconds);
    fmt::print("  {:>5} {:>7} {:>7} {:>11} {:>10} {:>10} {:>13}  {}\n", "level", "nodes", "leaves", "triangles",
               "geometry", "atlases", "min distance", "world texel");
    for (size_t l = 0; l < r.levels.size(); ++l) {
        const tiles::InspectLevel& L = r.levels[l];
        fmt::print("  {:>5} {:>7} {:>7} {:>11} {:>10} {:>10} {:>11.1f} m  {:.4f}..{:.4f} m\n", l, L.nodes, L.leaves,
                   L.triangles, humanBytes(L.bytes_geometry), humanBytes(L.bytes_atlases), L.min_distance_m,
                   L.world_texel_min_m, L.world_texel_max_m);
    }
    fmt::print("  geometry  {:>10} in {} files\n", humanBytes(r.bytes_geometry), r.geometry_files);
    fmt::print("  atlases   {:>10} in {} files\n", humanBytes(r.bytes_atlases), r.atlas_files);
    fmt::print("  textures  {:>10} in {} blocks: {} textures ({} held exactly by the atlases, {} unreadable: no "
               "original written)\n",
               humanBytes(r.bytes_textures), r.texture_blocks, r.textures, r.textures_exact, r.textures_unreadable);
    fmt::print("  texture economy: (atlases + textures) / originals as BC with mips ({}) = {:.2f}\n",
               humanBytes(r.bytes_originals_bc), r.texture_ratio);
    fmt::print("  features  {:>10} in {} tables: {} features\n", humanBytes(r.bytes_features), r.feature_tables,
               r.features);
    fmt::print("  total     {:>10}\n",
               humanBytes(r.bytes_geometry + r.bytes_atlases + r.bytes_textures + r.bytes_features));
}

int runInspect(const InspectCliOptions& opt) {
    std::error_code ec;
    if (!fs::is_directory(opt.folder, ec)) {
        return fail("inspect", Status::Io(fmt::format("{}: no such folder", opt.folder)));
    }
    if (!fs::exists(fs::path(opt.folder) / "tileset.json", ec)) {
        return fail("inspect", Status::Invalid(fmt::format("{}: no tileset.json: not a cityatlas tile folder", opt.folder)));
    }
    const auto t0 = std::chrono::steady_clock::now();
    const tiles::InspectResult r = tiles::inspectTileFolder(opt.folder, opt.threads);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!opt.quiet && r.nodes > 0) printSummary(opt.folder, r, seconds);
    std::fflush(stdout);
    if (r.ok()) {
        std::printf("OK: %llu files checked, no defects\n", static_cast<unsigned long long>(r.files_checked));
        return kExitOk;
    }
    for (const std::string& d : r.defects) note("inspect", d);
    return fail("inspect", Status::Invalid(fmt::format("{} defect(s)", r.defects.size())));
}

}  // namespace

RunFn addInspectCommand(CLI::App& app) {
    auto opt = std::make_shared<InspectCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "inspect",
        "Check a tile folder written by `cityatlas build`: tileset.json against its schema, every uri present\n"
        "with its recorded size, every Draco GLB and DDS decoded, feature tables and tree consistency. Prints a\n"
        "summary per level and exits 0 when no defect is found, else one line per defect and exit 1.");
    cmd->footer(
        "What is checked: tileset.json is validated against its schema (compiled in); every uri must name a file\n"
        "inside the folder (symlinks resolved) with the byte size the index gives; every Draco GLB must decode with\n"
        "its recorded triangle count, feature ids, the uv sets its node needs and feature, texture and material ids\n"
        "in range; every DDS (atlases and the textures inside texture blocks, which must fill their blocks back to\n"
        "back) must have a DXT1/DXT5 header matching its entry and exactly header + blocks bytes; every feature\n"
        "table must parse and hold its ids; the tree must be consistent (preorder ids, levels, quadrants, every\n"
        "child's halved atlas inside its parent's and apart from its siblings', children's boxes inside their\n"
        "parent's, a parent's min distance twice its children's largest sharp_from, geometric errors and texel\n"
        "sizes as the build parameters give them, totals).\n"
        "The texture economy line: (atlas bytes + original-block bytes) / (every used texture as BC with full\n"
        "mips), computed from the index's texture table: what the folder's textures cost over the data's own.\n"
        "Output: a summary per level on stdout and \"OK: N files checked, no defects\" (exit 0), or one line per\n"
        "defect on stderr, each starting with the file it concerns, and their count (exit 1). A missing folder or\n"
        "tileset.json is one line, exit 1.");
    cmd->add_option("folder", opt->folder, "The tile folder (holding tileset.json)")->required();
    cmd->add_option("--threads", opt->threads, "Threads decoding geometry (0 = all cores)")
        ->default_val(0)
        ->check(CLI::Range(0, 4096));
    cmd->add_flag("-q,--quiet", opt->quiet, "No summary: only the verdict (and the defects)");
    return [opt]() { return runInspect(*opt); };
}

}  // namespace cityatlas::cli
