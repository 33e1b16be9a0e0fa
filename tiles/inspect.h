// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Checks a tile folder written by the tiles stage (tiles/tileset.h), for
/// `cityatlas inspect` and the tests: tileset.json against its schema (compiled
/// in), every uri exists and is inside the folder, every block has the byte
/// size tileset.json gives, every geometry file decodes (Draco) with the
/// triangle count and attributes its node records, every DDS (atlases and the
/// textures inside texture blocks) has a valid header whose format, size and
/// mip count match its entry and whose length is exactly header + blocks,
/// the DDS files of a texture block fill it back to back, every feature table
/// parses and holds its ids; and the tree is consistent (ids in depth-first
/// preorder, levels, quadrants, every child's halved atlas inside its parent's
/// apart from its siblings', children boxes inside parents' boxes within
/// rounding, a parent's min_distance twice its children's largest sharp_from,
/// geometricError and world_texel_m as the build parameters give them,
/// geometric errors below world texel sizes, per-node feature counts and
/// tables as the geometry has them, totals as the entries add up).
///
/// tileset.json is read defensively: after schema errors every check that can
/// still run does, and no content (over-long strings, deep nesting, wrong
/// types, garbage files) makes it throw or crash. The defect list is the same
/// for any thread count.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace cityatlas::tiles {

struct InspectLevel {
    uint64_t nodes = 0, leaves = 0;
    uint64_t triangles = 0;
    uint64_t bytes_geometry = 0, bytes_atlases = 0;
    double min_distance_m = 0;  ///< largest over the level's nodes
    double world_texel_min_m = 0, world_texel_max_m = 0;
};

struct InspectResult {
    /// One line per defect: "<path relative to the folder or tileset.json>: <what>".
    std::vector<std::string> defects;
    std::vector<InspectLevel> levels;  ///< index = level
    uint64_t nodes = 0, leaves = 0;
    uint64_t files_checked = 0;
    /// Byte counts and triangles as tileset.json gives them (every file is checked against its entry).
    uint64_t bytes_geometry = 0, bytes_atlases = 0, bytes_textures = 0, bytes_features = 0;
    uint64_t textures = 0, texture_blocks = 0, features = 0;
    uint64_t triangles = 0, geometry_files = 0, atlas_files = 0, feature_tables = 0;
    uint64_t textures_unreadable = 0;  ///< texture entries whose original could not be read (leaves draw their atlas)
    uint64_t textures_exact = 0;       ///< texture entries the atlases hold at full resolution (no original written)
    uint64_t bytes_originals_bc = 0;   ///< every texture entry as BC with mips, from its width, height and format
    /// (atlases + texture blocks) / bytes_originals_bc, from the entries: what the folder's textures cost over the data's.
    double texture_ratio = 0;
    /// Computed textures (issue 19): names in the index's order, their files and bytes.
    std::vector<std::string> computed;
    uint64_t computed_files = 0, bytes_computed = 0;
    uint64_t blockmap_files = 0, bytes_blockmaps = 0;  ///< build --blockmaps
    bool ok() const { return defects.empty(); }
};

/// Inspects `folder`. Never throws on damaged content; every problem becomes a
/// defect line. `threads` 0 = all cores.
InspectResult inspectTileFolder(const std::filesystem::path& folder, int threads = 0);

}  // namespace cityatlas::tiles
