// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Small scenes and readers shared by the atlas tests (written here, not taken
// from the library, so the tests' geometry shares no code with what they check).

#include <array>
#include <filesystem>
#include <functional>
#include <optional>
#include <vector>

#include "core/geometry.h"
#include "core/status.h"
#include "ingest/citygml/citygml_reader.h"
#include "ingest/scene_sink.h"
#include "ingest/synth/town.h"

namespace cityatlas::test {

using Triangles = std::vector<std::array<Vec3d, 3>>;

/// A closed box as 12 outward triangles.
inline void addBox(const Vec3d& lo, const Vec3d& hi, Triangles* out) {
    const Vec3d c[8] = {{lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z},
                        {lo.x, lo.y, hi.z}, {hi.x, lo.y, hi.z}, {hi.x, hi.y, hi.z}, {lo.x, hi.y, hi.z}};
    const int quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
    for (const auto& q : quads) {
        out->push_back({c[q[0]], c[q[1]], c[q[2]]});
        out->push_back({c[q[0]], c[q[2]], c[q[3]]});
    }
}

/// A triangle's unit normal (its winding's).
inline Vec3d normalOf(const std::array<Vec3d, 3>& p) {
    const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
    return (1.0 / length(n)) * n;
}

/// A building's top: base + ridge.
inline double topOf(const synth::SynthBuilding& b) { return b.base_height_m + b.ridge_height_m; }

/// The first synthetic town of seeds 1..39 (`buildings`, `texture_px`) whose
/// tallest building (the first of equals) `accept` takes, with that
/// building's index; nullopt when none does.
inline std::optional<std::pair<synth::Town, size_t>> townWithTallest(
    uint32_t buildings, int texture_px, const std::function<bool(const synth::Town&, size_t tallest)>& accept) {
    for (uint64_t seed = 1; seed < 40; ++seed) {
        synth::TownSettings s;
        s.buildings = buildings;
        s.seed = seed;
        s.texture_size_px = texture_px;
        synth::Town town = synth::generateTown(s);
        size_t tallest = 0;
        for (size_t i = 1; i < town.buildings.size(); ++i)
            if (topOf(town.buildings[i]) > topOf(town.buildings[tallest])) tallest = i;
        if (accept(town, tallest)) return std::pair{std::move(town), tallest};
    }
    return std::nullopt;
}

/// A CityGML file read into a Scene with the default options.
inline Status readCityGmlScene(const std::filesystem::path& file, Scene* out) {
    SceneCollector collector;
    IngestState state;
    state.sink = &collector;
    const Status s = readCityGml(file, state);
    if (s.ok()) *out = std::move(collector.scene);
    return s;
}

}  // namespace cityatlas::test
