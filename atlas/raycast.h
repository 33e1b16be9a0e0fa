// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A CPU ray caster over scene triangles, for build-time analyses: computed
/// textures (the sky-view factor, visibility of a building, sun hours;
/// papers/000 §5.1.1, done with rays instead of the thesis' occlusion
/// queries, so results are deterministic and need no GPU).
///
/// Embree 3 does the work: a BVH over the triangles and its robust
/// (watertight) triangle test, so a ray through a shared edge or vertex of a
/// closed surface cannot slip between its triangles. Embree works in single
/// precision, so positions are stored relative to the caster's centre (the
/// midpoint of the triangles' box): 20 km from it a float is within 1 mm.
/// Rays are given in the scene's local frame, in double.
///
/// Answers depend only on the ray and the triangles, not on the thread count
/// or the order in which Embree built its tree: `occluded` is a yes/no, and
/// `nearest` returns the nearest distance; of several triangles hit at that
/// very distance (an edge, coplanar faces) it names the lowest index.
/// Degenerate triangles (zero area, non-finite corners) are left out; they
/// occlude nothing.

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "core/geometry.h"

namespace cityatlas::atlas {

/// Analyses cast from a surface start this far off it along its normal:
/// clear of the surface itself at float precision 10 km from the caster's centre.
inline constexpr double kSurfaceOffsetM = 0.01;

/// Where rays from `point` on a surface with outward `normal` (any length
/// but 0) start: kSurfaceOffsetM off it.
inline Vec3d surfaceRayOrigin(const Vec3d& point, const Vec3d& normal) {
    return point + (kSurfaceOffsetM / length(normal)) * normal;
}

struct RayHit {
    bool hit = false;
    double distance = std::numeric_limits<double>::infinity();  ///< along the (normalised) direction, metres
    uint32_t triangle = 0;                                       ///< index into the triangles given to build()
};

class RayCaster {
public:
    /// Builds the tree over `triangles` (local frame, metres). Never null;
    /// an empty list gives a caster that hits nothing.
    /// `threads`: Embree's build threads (0: all cores); the answers do not depend on it.
    static std::unique_ptr<RayCaster> build(const std::vector<std::array<Vec3d, 3>>& triangles, int threads = 0);
    ~RayCaster();
    RayCaster(const RayCaster&) = delete;
    RayCaster& operator=(const RayCaster&) = delete;

    /// Some triangle lies on the ray from `origin` along `direction` (any
    /// length but 0) within (near_m, far_m) metres. Safe from many threads.
    bool occluded(const Vec3d& origin, const Vec3d& direction, double near_m = 0,
                  double far_m = std::numeric_limits<double>::infinity()) const;
    /// The nearest triangle on that ray (ties: the lowest index). Safe from many threads.
    RayHit nearest(const Vec3d& origin, const Vec3d& direction, double near_m = 0,
                   double far_m = std::numeric_limits<double>::infinity()) const;

    size_t triangles() const { return kept_; }  ///< after degenerate ones were left out
    Vec3d centre() const { return centre_; }

private:
    RayCaster() = default;
    struct Impl;
    std::unique_ptr<Impl> impl_;
    Vec3d centre_{0, 0, 0};
    size_t kept_ = 0;
};

}  // namespace cityatlas::atlas
