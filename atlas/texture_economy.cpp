// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/texture_economy.h"

#include <algorithm>

#include <tbb/parallel_for.h>

#include "atlas/texel_budget.h"

namespace cityatlas::atlas {
namespace {

// The levels above the leaves hold a leaf's texels again, halved and tiled:
// about a third more (a full quadtree: 1/4 + 1/16 + ...).
constexpr double kLevelsAbove = 4.0 / 3.0;

struct Planned {
    double texels = 0;
    bool exact = true, promotable = true;
};

Planned planAt(const TextureModel& t, const AtlasParams& params, double d, bool promote) {
    ChartSettings cs;
    cs.d_min_m = d, cs.border_px = params.border_px, cs.atlas_size_px = params.atlas_size_px, cs.native = t.native;
    cs.promote = promote;
    const TextureRegions planned = planTextureRegions(t.members, cs);
    Planned p;
    for (const PlannedRegion& r : planned.regions) {
        p.texels += static_cast<double>(r.size.w) * r.size.h;
        const bool exact = r.single_colour || (r.size.native_u && r.size.native_v);
        p.exact &= exact;
        p.promotable &= exact || (r.uv_max.x > r.uv_min.x && r.uv_max.y > r.uv_min.y);
    }
    return p;
}

}  // namespace

TextureModelBuilder::TextureModelBuilder(size_t textures, double ppm) : TextureModelBuilder(0, textures, ppm) {}

TextureModelBuilder::TextureModelBuilder(size_t first, size_t end, double ppm, const uint32_t* reserve)
    : ppm_(ppm), first_(first), m_(end - first), bounds_(end - first) {
    if (reserve)
        for (size_t i = 0; i < m_.size(); ++i) {
            m_[i].members.reserve(reserve[i]);
            capacity_ += m_[i].members.capacity();
        }
}

void TextureModelBuilder::add(const Triangle& t) {
    if (t.texture < 0) return;
    const size_t i = static_cast<size_t>(t.texture) - first_;  // wraps below first_
    if (i >= m_.size()) return;
    const TexelDensity d = texelDensity(t);
    std::vector<ChartMember>& members = m_[i].members;
    const size_t before = members.capacity();
    members.push_back({d.uv_min, d.uv_max, d.s_world * ppm_, d.t_world * ppm_});
    capacity_ += members.capacity() - before;
    for (const Vec3d& p : t.position_local) bounds_[i].extend(p);
}

std::vector<TextureModel> TextureModelBuilder::finish(const TextureTable& textures, const AtlasParams& params) {
    std::vector<TextureModel> m = std::move(m_);
    std::vector<Box3d> bounds = std::move(bounds_);
    for (TextureModel& t : m) t.members.shrink_to_fit();
    for (size_t i = 0; i < m.size(); ++i) {
        const TextureInfo& r = textures[first_ + i];
        m[i].native = {std::max(0, r.width_px), std::max(0, r.height_px)};
        m[i].channels = r.channels == 4 ? 4 : 3;
        m[i].original_bytes =
            static_cast<double>(bcBytesWithMips(std::max(1, r.width_px), std::max(1, r.height_px), m[i].channels));
        if (!bounds[i].empty())
            m[i].x = 0.5 * (bounds[i].min.x + bounds[i].max.x), m[i].y = 0.5 * (bounds[i].min.y + bounds[i].max.y);
    }
    // Every triangle must still fit one atlas at full resolution (the
    // critical-triangle split does not know of promotions).
    const double room = params.atlas_size_px - 2.0 * params.border_px - 2.0;
    tbb::parallel_for(size_t{0}, m.size(), [&](size_t i) {
        TextureModel& t = m[i];
        if (t.members.empty() || t.native.w <= 0 || t.native.h <= 0) return;
        t.full_fits = std::all_of(t.members.begin(), t.members.end(), [&](const ChartMember& c) {
            return (c.uv_max.x - c.uv_min.x) * t.native.w <= room && (c.uv_max.y - c.uv_min.y) * t.native.h <= room;
        });
        if (!t.full_fits) return;
        const Planned full = planAt(t, params, 1.0, true);  // any distance: promoted regions are capped at full resolution
        t.full_texels = full.texels;
        t.full_exact = full.exact;
    });
    return m;
}

TexturePlan planTexture(const TextureModel& t, const AtlasParams& params, double d) {
    TexturePlan plan;
    if (t.members.empty()) return plan;
    const Planned at_d = planAt(t, params, d, false);
    plan.region_texels = at_d.texels;
    plan.exact = at_d.exact;
    if (at_d.exact || !at_d.promotable || !t.full_fits || !t.full_exact) return plan;
    const double original_texels = static_cast<double>(t.native.w) * t.native.h;
    if ((t.full_texels - at_d.texels) * kLevelsAbove <= original_texels) {
        plan.region_texels = t.full_texels;
        plan.exact = plan.promoted = true;
    }
    return plan;
}

}  // namespace cityatlas::atlas
