// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/texel_estimate.h"

#include <algorithm>
#include <cmath>

namespace cityatlas::atlas {

namespace {

double len2(const Vec2d& a) { return a.x * a.x + a.y * a.y; }
Vec2d sub(const Vec2d& a, const Vec2d& b) { return {a.x - b.x, a.y - b.y}; }

int roundUpToBlock(double texels) {
    // 1e-9 absorbs products like 0.1 * 40 that land a hair above an integer.
    const double t = std::ceil(texels - 1e-9);
    return static_cast<int>((std::max(4.0, t) + 3.0) / 4.0) * 4;
}

}  // namespace

TexelDensity texelDensity(const Triangle& t) {
    TexelDensity d;
    const auto& uv = t.uv;
    d.uv_min = {std::min({uv[0].x, uv[1].x, uv[2].x}), std::min({uv[0].y, uv[1].y, uv[2].y})};
    d.uv_max = {std::max({uv[0].x, uv[1].x, uv[2].x}), std::max({uv[0].y, uv[1].y, uv[2].y})};
    const Vec2d t1 = sub(uv[1], uv[0]), t2 = sub(uv[2], uv[0]);
    const double det = t1.x * t2.y - t1.y * t2.x;
    const double scale2 = std::max({len2(t1), len2(t2), len2(sub(uv[2], uv[1]))});
    if (scale2 == 0) {
        d.kind = TexelDensity::Kind::SingleColour;
        return d;
    }
    // Relative test: the uv triangle's area against its longest edge squared.
    if (std::abs(det) <= 1e-12 * scale2) {
        d.kind = TexelDensity::Kind::Collinear;
        int best = 0;
        double best_len2 = -1;
        for (int e = 0; e < 3; ++e) {
            const double l2 = len2(sub(uv[(e + 1) % 3], uv[e]));
            if (l2 > best_len2) best_len2 = l2, best = e;
        }
        const double stretch = length(t.position_local[(best + 1) % 3] - t.position_local[best]) / std::sqrt(best_len2);
        d.s_world = d.t_world = stretch;
        return d;
    }
    // P_T(Tex_T^-1(e)): solve a*t1 + b*t2 = e, then map a*v1 + b*v2.
    const Vec3d v1 = t.position_local[1] - t.position_local[0], v2 = t.position_local[2] - t.position_local[0];
    const double a_u = t2.y / det, b_u = -t1.y / det;  // e = (1, 0)
    const double a_v = -t2.x / det, b_v = t1.x / det;  // e = (0, 1)
    d.s_world = length(a_u * v1 + b_u * v2);
    d.t_world = length(a_v * v1 + b_v * v2);
    return d;
}

int borderFor(double content_texels, int max_border) {
    // A quarter of the content, at least one texel (bilinear filtering), at most the border asked for.
    return std::clamp(static_cast<int>(std::ceil(content_texels / 4.0 - 1e-9)), std::min(1, max_border), max_border);
}

namespace {

struct AxisSize {
    int total = 0, border = 0;
    double lo = 0, hi = 0, density = 0, content = 0;
    bool native = false;
};

// One axis of regionSize: `per` texels per unit wanted over [lo, hi].
AxisSize axisSize(double per, double lo, double hi, int max_border, int native) {
    AxisSize a;
    const double span = hi - lo;
    if (span <= 0) {  // a line in texture space: no extent to scale
        a.content = 1;
        a.border = borderFor(a.content, max_border);
        a.total = roundUpToBlock(a.content + 2.0 * a.border);
        a.lo = a.hi = lo;
        return a;
    }
    bool capped = native > 0 && per >= native;
    if (!capped) {
        // The rounding goes into the content's resolution (papers/000 §4.5.2,
        // f_hor and f_vert: the border shows the texture around the region).
        a.content = std::max(1.0, per * span);
        a.border = borderFor(a.content, max_border);
        a.total = roundUpToBlock(a.content + 2.0 * a.border);
        a.density = (a.total - 2.0 * a.border) / span;
        capped = native > 0 && a.density > native;  // the rounding would pass the texture's own resolution
        if (!capped) {
            a.lo = lo - a.border / a.density;
            a.hi = hi + a.border / a.density;
            return a;
        }
    }
    // Capped: the texture's own texels, whole ones, so the region copies them;
    // and from a multiple of 4 of the texture's texels, so the copy's 4x4
    // S3TC blocks are the original's blocks (the same block encodes the same
    // way: the atlas then looks as the original would). The border widens to
    // reach those boundaries. 1e-9 texels absorbs uv values a hair off a texel boundary.
    const double first = std::floor(lo * native + 1e-9), last = std::max(first + 1, std::ceil(hi * native - 1e-9));
    a.native = true;
    a.density = native;
    a.content = span * native;
    a.border = borderFor(a.content, max_border);
    const double start = 4 * std::floor((first - a.border) / 4), end = 4 * std::ceil((last + a.border) / 4);
    a.total = static_cast<int>(end - start);
    a.lo = start / native;
    a.hi = end / native;
    return a;
}

}  // namespace

RegionSize regionSize(double texels_per_u, double texels_per_v, Vec2d uv_min, Vec2d uv_max, int border,
                      NativeSize native) {
    const AxisSize u = axisSize(texels_per_u, uv_min.x, uv_max.x, border, native.w);
    const AxisSize v = axisSize(texels_per_v, uv_min.y, uv_max.y, border, native.h);
    RegionSize r;
    r.w = u.total, r.h = v.total;
    r.uv_min = {u.lo, v.lo}, r.uv_max = {u.hi, v.hi};
    r.native_u = u.native, r.native_v = v.native;
    r.density_u = u.density, r.density_v = v.density;
    r.content_w = u.content, r.content_h = v.content;
    r.border_u = u.border, r.border_v = v.border;
    return r;
}

namespace {

NativeSize nativeOf(const Triangle& t, std::span<const NativeSize> native) {
    return t.texture >= 0 && static_cast<size_t>(t.texture) < native.size() ? native[static_cast<size_t>(t.texture)]
                                                                            : NativeSize{};
}

// Texels the triangle alone needs along u and v at F pixels per metre, border
// excluded, and at most its texture's own texels over its uv box.
std::pair<double, double> contentTexels(const TexelDensity& d, double f, NativeSize n = {}) {
    if (d.kind == TexelDensity::Kind::SingleColour) return {1.0, 1.0};
    const double du = d.uv_max.x - d.uv_min.x, dv = d.uv_max.y - d.uv_min.y;
    double w = d.s_world * f * du, h = d.t_world * f * dv;
    if (n.w > 0) w = std::min(w, n.w * du + 2.0);  // capped: whole texels, up to one more at each end
    if (n.h > 0) h = std::min(h, n.h * dv + 2.0);
    return {std::max(1.0, w), std::max(1.0, h)};
}

bool isCritical(const Triangle& t, double f, int atlas_size, int border, std::span<const NativeSize> native) {
    if (t.texture < 0) return false;
    const auto [w, h] = contentTexels(texelDensity(t), f, nativeOf(t, native));
    return w + 2.0 * border > atlas_size || h + 2.0 * border > atlas_size;
}

// Splits at the midpoint of the edge whose texel extent is largest, until
// every piece fits. The density is the same affine map for every piece, so
// each halving shrinks the pieces' texel boxes and the recursion ends.
void splitUntilFits(const Triangle& t, double f, int atlas_size, int border, std::span<const NativeSize> native,
                    int depth, std::vector<Triangle>& out) {
    if (depth >= 60 || !isCritical(t, f, atlas_size, border, native)) {
        out.push_back(t);
        return;
    }
    const TexelDensity d = texelDensity(t);
    int edge = 0;
    double best = -1;
    for (int e = 0; e < 3; ++e) {
        const Vec2d duv = sub(t.uv[(e + 1) % 3], t.uv[e]);
        const double ext = std::max(std::abs(duv.x) * d.s_world, std::abs(duv.y) * d.t_world);
        if (ext > best) best = ext, edge = e;
    }
    const int a = edge, b = (edge + 1) % 3;
    const Vec3d pm = 0.5 * (t.position_local[a] + t.position_local[b]);
    const Vec2d tm{0.5 * (t.uv[a].x + t.uv[b].x), 0.5 * (t.uv[a].y + t.uv[b].y)};
    Triangle first = t, second = t;  // (a, m, third) and (m, b, third): orientation kept
    first.position_local[b] = pm, first.uv[b] = tm;
    second.position_local[a] = pm, second.uv[a] = tm;
    splitUntilFits(first, f, atlas_size, border, native, depth + 1, out);
    splitUntilFits(second, f, atlas_size, border, native, depth + 1, out);
}

}  // namespace

CriticalDistanceBuilder::CriticalDistanceBuilder(double d_min_requested_m, double pixels_per_metre_at_1m, int atlas_size,
                                                 int border, double critical_fraction, const TextureTable& textures)
    : d_req_(d_min_requested_m), ppm_(pixels_per_metre_at_1m), room_(atlas_size - 2.0 * border),
      fraction_(critical_fraction), textures_(textures) {}

// As nativeOf reads a copy (nativeSizes), from the table itself.
NativeSize CriticalDistanceBuilder::nativeSizeOf(const Triangle& t) const {
    if (t.texture < 0 || static_cast<size_t>(t.texture) >= textures_.size()) return {};
    const TextureInfo r = textures_[static_cast<size_t>(t.texture)];
    return {std::max(0, r.width_px), std::max(0, r.height_px)};
}

// The distance from which each triangle stops being critical: its content
// is inversely proportional to d_min, the border is not.
void CriticalDistanceBuilder::add(const Triangle& t) {
    if (t.texture < 0) return;
    ++textured_;
    const TexelDensity d = texelDensity(t);
    const double f = ppm_ / d_req_;
    const NativeSize n = nativeSizeOf(t);
    const auto [w, h] = contentTexels(d, f, n);
    if (std::max(w, h) <= room_) return;
    // An axis too large even capped fits once the resolution d_min asks for does.
    const auto [w0, h0] = contentTexels(d, f);
    fits_from_.push_back(d_req_ * std::max(w > room_ ? w0 : 0.0, h > room_ ? h0 : 0.0) / room_);
    // At its texture's own resolution a capped axis stops growing with 1/d.
    const double cap_w = n.w > 0 ? n.w * (d.uv_max.x - d.uv_min.x) + 2.0 : 1e300;
    const double cap_h = n.h > 0 ? n.h * (d.uv_max.y - d.uv_min.y) + 2.0 : 1e300;
    overshoot_cap_.emplace_back(fits_from_.back(), std::max(w > room_ ? cap_w : 0.0, h > room_ ? cap_h : 0.0) / room_);
}

CriticalResult CriticalDistanceBuilder::finish() {
    CriticalResult r;
    r.d_min_used_m = d_req_;
    std::vector<double>& fits_from = fits_from_;
    std::vector<std::pair<double, double>>& overshoot_cap = overshoot_cap_;  // (fits_from, largest capped content / room)
    const uint64_t textured = textured_;
    const double critical_fraction = fraction_;
    r.critical_at_requested = fits_from.size();
    const auto allowed = static_cast<uint64_t>(std::floor(critical_fraction * static_cast<double>(textured)));
    std::sort(fits_from.begin(), fits_from.end(), std::greater<>());
    std::sort(overshoot_cap.begin(), overshoot_cap.end(), std::greater<>());
    if (fits_from.size() > allowed) {
        // Keep exactly `allowed` critical: d_min becomes the (allowed+1)-th largest distance.
        r.d_min_used_m = fits_from[allowed] * (1.0 + 1e-12);
    }
    // Pieces grow with the square of the overshoot (a 1 km triangle at 1 m
    // would become millions): estimate them, and if splitting would add more
    // than the scene's textured triangles (at least 10,000), raise d_min
    // until it would not. The thesis' alternative for such scenes.
    auto pieces = [&](double d) {
        double n = 0;
        for (const auto& [from, capped] : overshoot_cap) {
            if (from <= d) break;
            // Halving stops once a piece fits, so pieces keep about a quarter
            // of the room's area or more: some 4 per room-sized cell of the
            // triangle's box, whose side is `overshoot` rooms (4.5 covers the
            // most measured, a 1 km triangle 70 rooms long: 21,043 pieces),
            // and 2 for one that barely overshoots.
            const double overshoot = std::min(from / d, capped);
            n += 2.0 + 4.5 * overshoot * overshoot;
        }
        return n;
    };
    const double budget = std::max(10000.0, static_cast<double>(textured));
    if (!fits_from.empty() && pieces(r.d_min_used_m) > budget) {
        double lo = r.d_min_used_m, hi = fits_from.front() * (1.0 + 1e-12);
        for (int k = 0; k < 100 && hi > lo * (1 + 1e-9); ++k) {
            const double mid = 0.5 * (lo + hi);
            (pieces(mid) > budget ? lo : hi) = mid;
        }
        r.d_min_used_m = hi;
        r.enlarged_for_split_budget = true;
    }
    return r;
}

void splitCriticalTriangles(std::vector<Triangle>& triangles, std::vector<uint32_t>& sources, double d_min_used_m,
                            double pixels_per_metre_at_1m, int atlas_size, int border, std::span<const NativeSize> native,
                            CriticalResult* result) {
    CriticalResult& r = *result;
    const double f = pixels_per_metre_at_1m / d_min_used_m;
    std::vector<Triangle> out;
    std::vector<uint32_t> out_sources;
    out.reserve(triangles.size());
    out_sources.reserve(triangles.size());
    for (size_t i = 0; i < triangles.size(); ++i) {
        const size_t before = out.size();
        if (isCritical(triangles[i], f, atlas_size, border, native)) {
            ++r.critical_after_enlarge;
            splitUntilFits(triangles[i], f, atlas_size, border, native, 0, out);
            ++r.triangles_split;
            r.triangles_added += out.size() - before - 1;
        } else {
            out.push_back(triangles[i]);
        }
        out_sources.insert(out_sources.end(), out.size() - before, sources.empty() ? uint32_t(i) : sources[i]);
    }
    triangles = std::move(out);
    sources = std::move(out_sources);
}


}  // namespace cityatlas::atlas
