// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/core/picking.h"

#include <cmath>

#include "render/core/blockmap_ray.h"

namespace cityatlas::render {

Vec3d pixelRay(const Camera& camera, double px, double py) {
    const Vec3d forward = normalized(camera.direction);
    Vec3d right = cross(forward, camera.up);
    if (length(right) < 1e-9) right = cross(forward, Vec3d{1, 0, 0});
    right = normalized(right);
    const Vec3d up = cross(right, forward);
    const double tan_v = std::tan(0.5 * camera.vertical_fov_deg * M_PI / 180.0);
    const double x = (2.0 * px / camera.width_px - 1.0) * tan_v * camera.aspect();
    const double y = (1.0 - 2.0 * py / camera.height_px) * tan_v;
    return normalized(forward + x * right + y * up);
}

PickHit pickRay(const Vec3d& origin, const Vec3d& dir, const std::vector<PickMesh>& meshes,
                const std::vector<PickBlockMap>& blockmaps) {
    PickHit best;
    for (const PickMesh& pm : meshes) {
        const MeshData& m = *pm.mesh;
        const Vec3d o = origin - pm.centre;  // into the node's frame: small numbers
        auto vertex = [&](uint32_t i) {
            return Vec3d{m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]};
        };
        for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
            const Vec3d a = vertex(m.indices[t]), b = vertex(m.indices[t + 1]), c = vertex(m.indices[t + 2]);
            const Vec3d e1 = b - a, e2 = c - a;
            const Vec3d p = cross(dir, e2);
            const double det = dot(e1, p);
            if (std::abs(det) < 1e-12) continue;  // parallel or degenerate
            const double inv = 1.0 / det;
            const Vec3d s = o - a;
            const double u = dot(s, p) * inv;
            if (u < 0 || u > 1) continue;
            const Vec3d q = cross(s, e1);
            const double v = dot(dir, q) * inv;
            if (v < 0 || u + v > 1) continue;
            const double d = dot(e2, q) * inv;
            if (d <= 0 || (best.hit && d >= best.distance_m)) continue;
            best.hit = true;
            best.distance_m = d;
            best.node = pm.node;
            best.feature = m.feature_id.empty() ? 0 : m.feature_id[m.indices[t]];
            best.point = origin + d * dir;
        }
    }
    for (const PickBlockMap& pb : blockmaps) {
        const format::BlockMap& bm = *pb.blockmap;
        const BlockMapHit h = castBlockMapRay(bm, origin, dir);
        if (!h.hit || (best.hit && h.t >= best.distance_m)) continue;
        const format::BlockMapCell& cell = bm.cells[bm.index(h.x, h.y)];
        if (!cell.occupied() || cell.feature >= bm.features.size()) continue;
        best.hit = true;
        best.distance_m = h.t;
        best.node = pb.node;
        best.feature = bm.features[cell.feature];
        best.point = origin + h.t * dir;
    }
    return best;
}

}  // namespace cityatlas::render
