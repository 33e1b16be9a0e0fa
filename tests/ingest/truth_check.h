// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Compares a Scene's statistics with a synthetic town's truth.json: counts
// exactly, areas per surface kind within 1e-9 relative (the truth's areas are
// exact facts about the file, see ingest/synth/town.h).

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "ingest/scene.h"

namespace cityatlas {

template <typename Json>
void expectStatsMatchTruth(const SceneStats& stats, const Json& truth) {
    EXPECT_EQ(stats.features, truth["buildings"].template get<size_t>());
    EXPECT_EQ(stats.textures, truth["textures"]["count"].template get<size_t>());
    EXPECT_EQ(stats.triangles, truth["triangles"].template get<size_t>());
    for (const auto& [name, tally] : truth["surfaces"].items()) {
        const auto sem = semanticFromName(name);
        ASSERT_TRUE(sem.has_value()) << name;
        const auto k = static_cast<size_t>(*sem);
        EXPECT_EQ(stats.triangles_by_semantic[k], tally["triangles"].template get<size_t>()) << name;
        const double a = tally["area_m2"].template get<double>();
        EXPECT_NEAR(stats.area_by_semantic_m2[k], a, 1e-9 * a) << name;
    }
}

}  // namespace cityatlas
