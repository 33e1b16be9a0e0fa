// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Picking without the GPU: a ray from the camera through a pixel, cast in
/// double against the geometry of the nodes drawn in the frame (positions
/// relative to each node's centre, as loaded). The nearest hit gives the
/// building's feature id; `view` shows its attributes from the feature tables.

#include <cstdint>
#include <vector>

#include "format/blockmap.h"
#include "render/core/decoded.h"
#include "render/core/view.h"

namespace cityatlas::render {

/// Unit direction of the ray through pixel (px, py), pixels from the top left
/// of the viewport (pixel centres at +0.5).
Vec3d pixelRay(const Camera& camera, double px, double py);

struct PickMesh {
    int32_t node = -1;
    const MeshData* mesh = nullptr;
    Vec3d centre;
};

/// A BlockMap drawn in the frame (its grid in the local frame).
struct PickBlockMap {
    int32_t node = -1;
    const format::BlockMap* blockmap = nullptr;
};

struct PickHit {
    bool hit = false;
    double distance_m = 0;
    uint32_t feature = 0;
    int32_t node = -1;
    Vec3d point;
};

/// The nearest triangle hit by the ray (Moller-Trumbore in double; both
/// faces), or the nearest prism of a BlockMap (render/core/blockmap_ray.h,
/// as its shader draws it) when that is nearer.
PickHit pickRay(const Vec3d& origin, const Vec3d& direction, const std::vector<PickMesh>& meshes,
                const std::vector<PickBlockMap>& blockmaps = {});

}  // namespace cityatlas::render
