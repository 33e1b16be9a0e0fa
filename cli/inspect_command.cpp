// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas inspect`: checks a tile folder and summarises its tree.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include <algorithm>
#include <fstream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "cli/build_hash.h"
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
    bool json = false;
};

// Files a build writes whatever its inputs' contents: the build report
// (times, memory) and the index itself (dumped structurally instead).
bool isVolatileFile(const std::string& relative) { return relative == "build_report.json" || relative == "tileset.json"; }

// The folder as canonical JSON, for goldens: the verdict, the summary, the
// index without what changes between equal builds (the generator's version,
// tilesetVersion: a hash that includes the input paths), and every other
// file's size and XXH3 in path order. Equal for equal outputs, on any machine
// and in any folder.
nlohmann::ordered_json canonicalDump(const fs::path& folder, const tiles::InspectResult& r) {
    nlohmann::ordered_json j;
    j["format"] = "cityatlas-inspect-1";
    j["ok"] = r.ok();
    j["defects"] = r.defects;
    j["summary"] = {{"nodes", r.nodes},
                    {"leaves", r.leaves},
                    {"levels", r.levels.size()},
                    {"triangles", r.triangles},
                    {"bytes", {{"geometry", r.bytes_geometry}, {"atlases", r.bytes_atlases},
                               {"textures", r.bytes_textures}, {"features", r.bytes_features}}},
                    {"textures", r.textures},
                    {"texture_blocks", r.texture_blocks},
                    {"features", r.features},
                    {"texture_ratio", r.texture_ratio}};
    std::ifstream in(folder / "tileset.json");
    nlohmann::ordered_json tileset = nlohmann::ordered_json::parse(in, nullptr, false);
    if (tileset.is_object() && tileset.contains("asset") && tileset["asset"].is_object()) {
        tileset["asset"].erase("generator");
        tileset["asset"].erase("tilesetVersion");
    }
    j["tileset"] = tileset.is_discarded() ? nlohmann::ordered_json() : tileset;
    std::vector<std::string> files;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(folder, ec); !ec && it != fs::recursive_directory_iterator();
         it.increment(ec))
        if (it->is_regular_file(ec)) files.push_back(fs::relative(it->path(), folder).generic_string());
    std::sort(files.begin(), files.end());
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const std::string& f : files) {
        if (isVolatileFile(f)) continue;
        FileDigest d;
        if (Status s = digestFile(folder / f, &d); !s.ok()) {
            list.push_back({{"path", f}, {"error", s.error}});
            continue;
        }
        list.push_back({{"path", f}, {"bytes", d.bytes}, {"xxh3", d.xxh3}});
    }
    j["files"] = std::move(list);
    return j;
}

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
    if (!r.computed.empty())
        fmt::print("  computed  {:>10} in {} files: {} (BC4; not in the total)\n", humanBytes(r.bytes_computed),
                   r.computed_files, fmt::join(r.computed, ", "));
    if (r.blockmap_files)
        fmt::print("  blockmaps {:>10} in {} files (the far field; not in the total)\n", humanBytes(r.bytes_blockmaps),
                   r.blockmap_files);
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
    if (opt.json) {
        std::printf("%s\n", canonicalDump(opt.folder, r).dump(1).c_str());
        return r.ok() ? kExitOk : kExitFailure;
    }
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
    cmd->add_flag("--json", opt->json,
                  "Print the folder as canonical JSON on stdout instead: verdict and defects, the summary, tileset.json "
                  "without its volatile fields (asset.generator, asset.tilesetVersion) and every other file's size and "
                  "XXH3 (build_report.json left out: times). Equal for equal outputs in any folder; what the goldens "
                  "in tests/golden hold. Exit status as without it.");
    return [opt]() { return runInspect(*opt); };
}

}  // namespace cityatlas::cli
