// SPDX-License-Identifier: GPL-3.0-or-later
// Names, parameter checks and the small geometric maps of atlas_tree.h.
#include <cmath>

#include <fmt/format.h>

#include "atlas/atlas_tree.h"

namespace cityatlas::atlas {

std::string_view layerName(Layer l) { return l == Layer::Opaque ? "opaque" : "alpha"; }

std::string_view filterName(ResampleFilter f) {
    switch (f) {
        case ResampleFilter::Box: return "box";
        case ResampleFilter::Triangle: return "triangle";
        case ResampleFilter::Mitchell: return "mitchell";
        case ResampleFilter::Lanczos3: return "lanczos3";
    }
    return "?";
}

std::optional<ResampleFilter> filterFromName(std::string_view name) {
    for (auto f : {ResampleFilter::Box, ResampleFilter::Triangle, ResampleFilter::Mitchell, ResampleFilter::Lanczos3})
        if (filterName(f) == name) return f;
    return std::nullopt;
}

Status validateParams(const AtlasParams& p) {
    const int a = p.atlas_size_px;
    if (a < 64 || a > 4096 || (a & (a - 1)) != 0)
        return Status::Usage(fmt::format("atlas size (--atlas-size) {} must be a power of two from 64 to 4096", a));
    if (p.border_px < 0 || p.border_px >= a / 4)
        return Status::Usage(fmt::format("border (--border) {} texels must be in [0, {}) for atlas size {}", p.border_px, a / 4, a));
    if (p.screen_width_px < 1 || p.screen_height_px < 1)
        return Status::Usage("screen size (--screen) must be positive");
    if (!(p.vertical_fov_deg > 0 && p.vertical_fov_deg < 170))
        return Status::Usage(fmt::format("vertical field of view (--fov) {} must be in (0, 170) degrees", p.vertical_fov_deg));
    if (p.d_min_m && !(*p.d_min_m > 0 && std::isfinite(*p.d_min_m)))
        return Status::Usage(fmt::format("d_min (--d-min) {} m must be positive", *p.d_min_m));
    if (!(p.d_min_diagonal_fraction > 0 && p.d_min_diagonal_fraction <= 1))
        return Status::Usage("d_min (--d-min D/N) as a fraction of the scene diagonal must be in (0, 1]");
    if (!(p.critical_fraction >= 0 && p.critical_fraction <= 1))
        return Status::Usage("the critical-triangle fraction (--critical-percent) must be in [0, 100] %");
    if (p.threads < 0) return Status::Usage("threads (--threads) must be >= 0");
    if (p.cache_mb < 16) return Status::Usage("the texture cache (--cache-mb) needs at least 16 MB");
    return Status::Ok();
}

ProjectionBound projectionBound(const AtlasParams& p) {
    ProjectionBound b;
    const double half_h = 0.5 * p.screen_height_px, half_w = 0.5 * p.screen_width_px;
    b.focal_px = half_h / std::tan(0.5 * p.vertical_fov_deg * M_PI / 180.0);
    const double tan2 = (half_w * half_w + half_h * half_h) / (b.focal_px * b.focal_px);
    b.corner_factor = 1.0 + tan2;
    return b;
}

namespace {
// Position of `value` in [lo, hi] as a fraction; the middle for an empty span
// (a texture region of one colour, or a line in texture space).
double fraction(double value, double lo, double hi) { return hi > lo ? (value - lo) / (hi - lo) : 0.5; }
}  // namespace

Vec2d PackedRegion::toAtlasTexels(const Vec2d& uv) const {
    const double fu = fraction(uv.x, uv_min.x, uv_max.x), fv = fraction(uv.y, uv_min.y, uv_max.y);
    if (!rotated) return {x + fu * w, y + fv * h};
    // Turned a quarter counter-clockwise: u runs up the atlas, v runs right to left.
    return {x + (1.0 - fv) * w, y + fu * h};
}

Vec2d PackedRegion::toTexture(const Vec2d& texel) const {
    const double fx = (texel.x - x) / w, fy = (texel.y - y) / h;
    if (!rotated) return {uv_min.x + fx * (uv_max.x - uv_min.x), uv_min.y + fy * (uv_max.y - uv_min.y)};
    return {uv_min.x + fy * (uv_max.x - uv_min.x), uv_min.y + (1.0 - fx) * (uv_max.y - uv_min.y)};
}


}  // namespace cityatlas::atlas
