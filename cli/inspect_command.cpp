// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas inspect`: checks a tile folder and summarises its tree.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "cli/progress.h"
#include "tiles/inspect.h"

namespace cityatlas::cli {
namespace {

struct InspectCliOptions {
    std::string folder;
    int threads = 0;
    bool quiet = false;
};

int runInspect(const InspectCliOptions& opt) {
    const tiles::InspectResult r = tiles::inspectTileFolder(opt.folder, opt.threads);
    if (!opt.quiet && r.nodes > 0) {
        std::printf("%s: %llu nodes (%llu leaves), %zu levels\n", opt.folder.c_str(),
                    static_cast<unsigned long long>(r.nodes), static_cast<unsigned long long>(r.leaves), r.levels.size());
        std::printf("  level  nodes  leaves   triangles    geometry     atlases  min distance   world texel\n");
        for (size_t l = 0; l < r.levels.size(); ++l) {
            const tiles::InspectLevel& L = r.levels[l];
            std::printf("  %5zu %6llu %7llu %11llu %11s %11s %11.1f m  %.3f..%.3f m\n", l,
                        static_cast<unsigned long long>(L.nodes), static_cast<unsigned long long>(L.leaves),
                        static_cast<unsigned long long>(L.triangles), humanBytes(L.bytes_geometry).c_str(),
                        humanBytes(L.bytes_atlases).c_str(), L.min_distance_m, L.world_texel_min_m, L.world_texel_max_m);
        }
        std::printf("  textures %llu in %llu blocks (%s), features %llu (%s); geometry %s, atlases %s\n",
                    static_cast<unsigned long long>(r.textures), static_cast<unsigned long long>(r.texture_blocks),
                    humanBytes(r.bytes_textures).c_str(), static_cast<unsigned long long>(r.features),
                    humanBytes(r.bytes_features).c_str(), humanBytes(r.bytes_geometry).c_str(),
                    humanBytes(r.bytes_atlases).c_str());
    }
    if (r.ok()) {
        std::printf("OK: %llu files checked, no defects\n", static_cast<unsigned long long>(r.files_checked));
        return kExitOk;
    }
    for (const std::string& d : r.defects) std::fprintf(stderr, "cityatlas inspect: %s\n", d.c_str());
    std::fprintf(stderr, "cityatlas inspect: %zu defect(s) in %s\n", r.defects.size(), opt.folder.c_str());
    return kExitFailure;
}

}  // namespace

RunFn addInspectCommand(CLI::App& app) {
    auto opt = std::make_shared<InspectCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "inspect",
        "Check a tile folder written by `cityatlas build`: tileset.json against its schema, every uri exists inside\n"
        "the folder with the byte size the index gives, every Draco mesh decodes with its triangle count and ids in\n"
        "range, every DDS header (atlases and the textures inside blocks) matches its entry, every feature table\n"
        "parses, and the tree is consistent. Prints a summary per level. Exit 0: no defect; 1: defects, one line\n"
        "each on stderr, naming the file.");
    cmd->add_option("folder", opt->folder, "The tile folder (holding tileset.json)")->required();
    cmd->add_option("--threads", opt->threads, "Worker threads for decoding (0 = all cores)")->default_val(0);
    cmd->add_flag("-q,--quiet", opt->quiet, "Only the verdict");
    return [opt]() { return runInspect(*opt); };
}

}  // namespace cityatlas::cli
