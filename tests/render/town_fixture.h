// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A small synthetic town built into a tile folder once per test process
// (25 buildings, 64 px textures, d_min 150 m, atlas 256 px): the real output
// of the tiles stage for the client's tests.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "atlas/atlas_tree.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "tests/ingest/test_support.h"
#include "tiles/tileset.h"

namespace cityatlas::render::test {

struct BuiltTown {
    std::filesystem::path dir;  ///< the tile folder is dir / "tiles"
    atlas::AtlasTree tree;
    std::string text;           ///< tileset.json
};

/// `blockmaps`: also build --blockmaps complement (a BlockMap on the root).
inline BuiltTown buildTown(const char* name, bool blockmaps) {
    namespace fs = std::filesystem;
    BuiltTown t;
    t.dir = cityatlas::test::scratchPath(name, "town");
    synth::TownSettings settings;
    settings.buildings = 25;
    settings.seed = 5;
    settings.texture_size_px = 64;
    const synth::Town town = synth::generateTown(settings);
    EXPECT_TRUE(synth::writeTown(town, t.dir / "town", false, {}).ok());
    const Scene scene = synth::townToScene(town, t.dir / "town");
    atlas::AtlasParams ap;
    ap.d_min_m = 150;
    ap.atlas_size_px = 256;
    Diagnostics diagnostics;
    EXPECT_TRUE(atlas::buildAtlasTree(scene, ap, t.dir / "work", diagnostics, {}, &t.tree).ok());
    fs::create_directories(t.dir / "tiles");
    tiles::TilesParams tp;
    tp.threads = 2;
    if (blockmaps) tp.blockmaps = tiles::BlockMapMode::Complement;
    tiles::TilesStats stats;
    EXPECT_TRUE(tiles::writeTileset(scene, t.tree, t.dir / "work", tp, t.dir / "tiles", "00112233445566ff", diagnostics,
                                    {}, &stats)
                    .ok());
    std::ifstream f(t.dir / "tiles" / "tileset.json");
    std::stringstream ss;
    ss << f.rdbuf();
    t.text = ss.str();
    return t;
}

inline const BuiltTown& builtTown() {
    static const BuiltTown t = buildTown("render_town", false);
    return t;
}

/// The same town with BlockMaps (issue 20).
inline const BuiltTown& builtTownWithBlockMaps() {
    static const BuiltTown t = buildTown("render_town_blockmaps", true);
    return t;
}

}  // namespace cityatlas::render::test
