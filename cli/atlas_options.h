// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The atlas-tree options, shared by `atlas` and `build`.

#include <string>

#include <CLI/CLI.hpp>

#include "atlas/atlas_tree.h"
#include "core/status.h"

namespace cityatlas::cli {

struct AtlasTreeOptions {
    std::string d_min = "auto";
    std::string screen = "1920x1080";
    std::string filter = "lanczos3";
    std::string packing = "maxrects";
    double critical_percent = 10;
    atlas::AtlasParams params;
};

/// Registers --d-min, --atlas-size, --border, --screen, --fov, --filter,
/// --packing, --unique-charts, --critical-percent, --threads, --cache-mb and --models-mb.
void addAtlasTreeOptions(CLI::App* cmd, AtlasTreeOptions* opt);

/// Options -> parameters; the message names the bad option.
Status parseAtlasTreeOptions(const AtlasTreeOptions& opt, atlas::AtlasParams* p);

/// "d_min 212 m, chosen from the data: ..." (with any enlargement for critical triangles).
std::string dMinSentence(const atlas::AtlasStats& s);

/// "textures: 108 of 108 held exactly (no originals needed); atlases + originals = 1.62x the originals as BC".
std::string textureEconomySentence(const atlas::AtlasStats& s);

}  // namespace cityatlas::cli
