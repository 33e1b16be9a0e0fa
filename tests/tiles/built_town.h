// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A synthetic town built through the atlas and tiles stages in-process, for
// the tests of what the tiles stage writes (tests/tiles/test_tileset.cpp,
// test_tiles3d.cpp).
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "atlas/atlas_tree.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "tests/ingest/test_support.h"
#include "tiles/tileset.h"

namespace cityatlas::tiles {
namespace fs = std::filesystem;
using nlohmann::json;

inline std::vector<uint8_t> readFile(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

inline Vec3d vec3(const json& a) { return {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()}; }

struct Built {
    Scene scene;
    atlas::AtlasTree tree;
    TilesStats stats;
    fs::path dir, atlas_dir;
    json tileset;
};

// A town of `buildings` (textures of 64 px: fast), moved by `offset` in its
// local frame, built into a tile folder.
inline std::unique_ptr<Built> buildTown(const std::string& name, uint32_t buildings, const Vec3d& offset,
                                 const TilesParams& params, double d_min_m = 150,
                                 const std::function<void(const Built&)>& before_tiles = {},
                                 Diagnostics* tiles_diagnostics = nullptr, int texture_px = 64,
                                 bool hand_off_in_memory = false) {
    auto b = std::make_unique<Built>();
    b->dir = test::scratchPath("tileset", name);
    synth::TownSettings settings;
    settings.buildings = buildings;
    settings.seed = 11;
    settings.texture_size_px = texture_px;
    const synth::Town town = synth::generateTown(settings);
    EXPECT_TRUE(synth::writeTown(town, b->dir / "town", false, {}).ok());
    b->scene = synth::townToScene(town, b->dir / "town");
    for (Triangle& t : b->scene.triangles)
        for (Vec3d& p : t.position_local) p = p + offset;
    atlas::AtlasParams ap;
    ap.d_min_m = d_min_m;
    ap.atlas_size_px = 256;
    b->atlas_dir = b->dir / "work";
    Diagnostics diagnostics;
    // As `build` does it: atlases encoded as they are rendered, no PNG.
    AtlasHandOff hand_off(params.bc_quality, b->dir / "tiles");
    const Status st = atlas::buildAtlasTree(b->scene, ap, b->atlas_dir, diagnostics, {}, &b->tree,
                                            hand_off_in_memory ? hand_off.sink() : atlas::AtlasImageSink());
    EXPECT_TRUE(st.ok()) << st.error;
    const EncodedAtlases encoded = hand_off.take(b->tree.nodes.size());
    if (before_tiles) before_tiles(*b);
    fs::create_directories(b->dir / "tiles");
    Diagnostics& tiles_diag = tiles_diagnostics ? *tiles_diagnostics : diagnostics;
    const Status w = writeTileset(b->scene, b->tree, b->atlas_dir, params, b->dir / "tiles", "0123456789abcdef",
                                  tiles_diag, {}, &b->stats, hand_off_in_memory ? &encoded : nullptr);
    EXPECT_TRUE(w.ok()) << w.error;
    std::ifstream f(b->dir / "tiles" / "tileset.json");
    b->tileset = json::parse(f);
    return b;
}

}  // namespace cityatlas::tiles
