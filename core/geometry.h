// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The small geometry both sides of cityatlas share (the pipeline that writes
/// tile folders and the client that reads them): double-precision vectors and
/// boxes, in metres unless a name says otherwise. Header-only, no dependencies.

#include <algorithm>
#include <cmath>

namespace cityatlas {

struct Vec2d {
    double x = 0, y = 0;
    friend bool operator==(const Vec2d&, const Vec2d&) = default;
};

struct Vec3d {
    double x = 0, y = 0, z = 0;
    friend bool operator==(const Vec3d&, const Vec3d&) = default;
};

inline Vec3d operator-(const Vec3d& a, const Vec3d& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3d operator+(const Vec3d& a, const Vec3d& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3d operator*(double s, const Vec3d& a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(const Vec3d& a, const Vec3d& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3d cross(const Vec3d& a, const Vec3d& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(const Vec3d& a) { return std::sqrt(dot(a, a)); }

/// Axis-aligned box; empty while min > max.
struct Box3d {
    Vec3d min{1e300, 1e300, 1e300};
    Vec3d max{-1e300, -1e300, -1e300};
    bool empty() const { return min.x > max.x; }
    void extend(const Vec3d& p) {
        min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
        max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
    }
};

}  // namespace cityatlas
