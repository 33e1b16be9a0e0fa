// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/scene.h"

#include <algorithm>
#include <cmath>

namespace cityatlas {

double length(const Vec3d& a) { return std::sqrt(dot(a, a)); }

void Box3d::extend(const Vec3d& p) {
    min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
    max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
}

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

namespace {
// Neumaier summation: totals over millions of triangles stay within a few ulps,
// which the 1e-9 relative area checks against generator truth rely on.
struct CompensatedSum {
    double sum = 0, correction = 0;
    void add(double x) {
        double t = sum + x;
        correction += std::abs(sum) >= std::abs(x) ? (sum - t) + x : (x - t) + sum;
        sum = t;
    }
    double value() const { return sum + correction; }
};
}  // namespace

SceneStats computeStats(const Scene& scene) {
    SceneStats stats;
    stats.triangles = scene.triangles.size();
    stats.features = scene.features.size();
    stats.textures = scene.textures.size();
    std::array<CompensatedSum, kSurfaceSemanticCount> area;
    for (const Triangle& t : scene.triangles) {
        auto k = static_cast<size_t>(t.semantic);
        stats.triangles_by_semantic[k]++;
        area[k].add(triangleArea(t.position_local));
        if (t.texture >= 0) stats.textured_triangles++;
        for (const Vec3d& p : t.position_local) stats.bounds_local.extend(p);
    }
    for (size_t k = 0; k < area.size(); ++k) stats.area_by_semantic_m2[k] = area[k].value();
    return stats;
}

}  // namespace cityatlas
