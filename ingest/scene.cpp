// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/scene.h"

#include <algorithm>
#include <cmath>

namespace cityatlas {

std::string_view semanticName(SurfaceSemantic s) {
    switch (s) {
        case SurfaceSemantic::Unclassified: return "unclassified";
        case SurfaceSemantic::Wall: return "wall";
        case SurfaceSemantic::Roof: return "roof";
        case SurfaceSemantic::Ground: return "ground";
        case SurfaceSemantic::Closure: return "closure";
        case SurfaceSemantic::OuterFloor: return "outer_floor";
        case SurfaceSemantic::OuterCeiling: return "outer_ceiling";
        case SurfaceSemantic::Installation: return "installation";
    }
    return "unclassified";
}

std::optional<SurfaceSemantic> semanticFromName(std::string_view name) {
    for (int k = 0; k < kSurfaceSemanticCount; ++k)
        if (semanticName(static_cast<SurfaceSemantic>(k)) == name) return static_cast<SurfaceSemantic>(k);
    return std::nullopt;
}

std::string_view wrapModeName(WrapMode w) {
    switch (w) {
        case WrapMode::None: return "none";
        case WrapMode::Wrap: return "wrap";
        case WrapMode::Mirror: return "mirror";
        case WrapMode::Clamp: return "clamp";
        case WrapMode::Border: return "border";
    }
    return "none";
}

int32_t Scene::internMaterial(const Material& m) {
    auto it = std::find(materials.begin(), materials.end(), m);
    if (it != materials.end()) return static_cast<int32_t>(it - materials.begin());
    materials.push_back(m);
    return static_cast<int32_t>(materials.size() - 1);
}

double triangleArea(const std::array<Vec3d, 3>& p) {
    return 0.5 * length(cross(p[1] - p[0], p[2] - p[0]));
}

// Neumaier summation: totals over millions of triangles stay within a few ulps,
// which the 1e-9 relative area checks against generator truth rely on.
void SceneStatsAccumulator::add(const Triangle& t) {
    const auto k = static_cast<size_t>(t.semantic);
    stats_.triangles++;
    stats_.triangles_by_semantic[k]++;
    const double x = triangleArea(t.position_local);
    const double sum = sum_[k] + x;
    correction_[k] += std::abs(sum_[k]) >= std::abs(x) ? (sum_[k] - sum) + x : (x - sum) + sum_[k];
    sum_[k] = sum;
    if (t.texture >= 0) stats_.textured_triangles++;
    for (const Vec3d& p : t.position_local) stats_.bounds_local.extend(p);
}

SceneStats SceneStatsAccumulator::finish() const {
    SceneStats s = stats_;
    for (size_t k = 0; k < sum_.size(); ++k) s.area_by_semantic_m2[k] = sum_[k] + correction_[k];
    return s;
}

SceneStats computeStats(const Scene& scene) {
    SceneStatsAccumulator acc;
    for (const Triangle& t : scene.triangles) acc.add(t);
    SceneStats stats = acc.finish();
    stats.features = scene.features.size();
    stats.textures = scene.textures.size();
    return stats;
}

}  // namespace cityatlas
