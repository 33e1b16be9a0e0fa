// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/default_dmin.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <unordered_map>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "atlas/texel_budget.h"
#include "atlas/texture_economy.h"

namespace cityatlas::atlas {
namespace {

// What a tree costs over its regions planned scene-wide: leaf atlases hold
// their regions at about 85 % coverage once sized to them, the levels above
// add some 40 % (compacted halves), and regions of a chart cut between
// leaves are paid twice. Measured 1.58-1.75 on the synthetic towns and the
// shared real data; the larger value, so the estimate errs high.
constexpr double kTreeOverRegions = 1.75;
// Candidates estimated past the first that qualifies, for the report's curve
// (the rest cost time: every candidate plans every texture).
constexpr int kShownAfterTheChoice = 3;

DminEstimate estimateAt(const std::vector<TextureModel>& textures, const AtlasParams& params, double d) {
    std::vector<TexturePlan> plans(textures.size());
    tbb::parallel_for(size_t{0}, textures.size(), [&](size_t i) { plans[i] = planTexture(textures[i], params, d); });
    DminEstimate e;
    e.d_m = d;
    // Originals within d of a camera: their textures' centres binned in cells
    // of d/4; a camera in a cell reaches the cells whose centres lie within d
    // of its own (a disc of radius d, to a quarter cell).
    const double cell = d / 4;
    std::unordered_map<int64_t, double> cells;
    auto key = [](int64_t cx, int64_t cy) { return (cx << 32) ^ (cy & 0xffffffff); };
    for (size_t i = 0; i < textures.size(); ++i) {
        const TextureModel& t = textures[i];
        if (t.members.empty()) continue;
        // BC1 half a byte per texel, BC3 one; mips add a third.
        e.atlas_bytes += plans[i].region_texels * (t.channels == 4 ? 1.0 : 0.5) * 4.0 / 3.0 * kTreeOverRegions;
        e.originals_used_bytes += t.original_bytes;
        if (plans[i].exact) continue;
        e.originals_needed_bytes += t.original_bytes;
        cells[key(static_cast<int64_t>(std::floor(t.x / cell)), static_cast<int64_t>(std::floor(t.y / cell)))] +=
            t.original_bytes;
    }
    for (const auto& entry : cells) {
        const int64_t cx = entry.first >> 32, cy = static_cast<int32_t>(entry.first & 0xffffffff);
        double sum = 0;
        for (int64_t dx = -4; dx <= 4; ++dx)
            for (int64_t dy = -4; dy <= 4; ++dy)
                if (dx * dx + dy * dy <= 16)
                    if (const auto it = cells.find(key(cx + dx, cy + dy)); it != cells.end()) sum += it->second;
        e.originals_within_bytes = std::max(e.originals_within_bytes, sum);
    }
    e.ratio = e.originals_used_bytes > 0 ? (e.atlas_bytes + e.originals_needed_bytes) / e.originals_used_bytes : 0;
    return e;
}

}  // namespace

std::vector<DminEstimate> estimateDminCandidates(const std::vector<TextureModel>& textures, double diagonal_m,
                                                 const AtlasParams& params,
                                                 const std::function<bool(const DminEstimate&)>& enough) {
    // Below `lo` every triangle's texture is capped on both axes, so nothing
    // changes; above `hi` every one is below its own resolution.
    double lo = 1e300, hi = 0;
    for (const TextureModel& tm : textures)
        for (const ChartMember& m : tm.members) {
            const double du = tm.native.w > 0 ? m.per_u_1m / tm.native.w : 0;
            const double dv = tm.native.h > 0 ? m.per_v_1m / tm.native.h : 0;
            const double least = std::min(du > 0 ? du : dv, dv > 0 ? dv : du);
            if (least > 0) lo = std::min(lo, least);
            hi = std::max({hi, du, dv});
        }
    std::vector<DminEstimate> out;
    if (lo >= 1e300) return out;
    // Beyond both, atlases keep shrinking (as 1/d^2) while the originals stay:
    // a few more octaves show where the ratio settles.
    hi = 16.0 * std::max({hi, diagonal_m, lo});
    int after_enough = -1;  // candidates still to show once `enough` said yes
    for (double d = lo;; d *= std::sqrt(2.0)) {
        out.push_back(estimateAt(textures, params, std::min(d, hi)));
        if (after_enough < 0 && enough && enough(out.back())) after_enough = kShownAfterTheChoice;
        if (d >= hi || after_enough-- == 0) break;
    }
    return out;
}

DminChoice chooseDefaultDmin(const std::vector<TextureModel>& textures, double diagonal, const AtlasParams& params,
                             double* d_min_m, const DminRule& rule) {
    const double limit = rule.originals_within_mb * 1e6;
    auto qualifies = [&](const DminEstimate& e) {
        return e.originals_within_bytes <= limit && e.ratio <= rule.ratio_target;
    };
    const std::vector<DminEstimate> c = estimateDminCandidates(textures, diagonal, params, qualifies);
    if (c.empty()) {
        *d_min_m = diagonal * params.d_min_diagonal_fraction;
        return {"diagonal-fraction",
                fmt::format("no textures to size: the scene diagonal {:.0f} m / {:.3g}", diagonal,
                            1.0 / params.d_min_diagonal_fraction),
                0, 0, {}};
    }
    const DminEstimate* pick = nullptr;
    for (const DminEstimate& e : c)
        if (qualifies(e)) {
            pick = &e;
            break;
        }
    std::string why;
    if (pick) {
        why = fmt::format("the smallest distance at which atlases plus the originals still needed are estimated at "
                          "{:.2f}x the original textures (target {:.1f}x)", pick->ratio, rule.ratio_target);
    } else {
        for (const DminEstimate& e : c)
            if (e.originals_within_bytes <= limit && (!pick || e.ratio < pick->ratio)) pick = &e;
        if (!pick) pick = &c.front();  // nothing within the load bound: the least load
        why = fmt::format("the cheapest distance found: atlases plus the originals still needed estimated at {:.2f}x "
                          "the original textures (target {:.1f}x not reachable)", pick->ratio, rule.ratio_target);
    }
    *d_min_m = pick->d_m;
    why += fmt::format(", with at most {:.1f} MB of originals within d_min of any camera (limit {:.0f} MB)",
                       pick->originals_within_bytes / 1e6, rule.originals_within_mb);
    DminChoice choice{"data", why, pick->ratio, pick->originals_within_bytes / 1e6, {}};
    for (const DminEstimate& e : c) choice.candidates.push_back({e.d_m, e.ratio, e.originals_within_bytes / 1e6});
    return choice;
}

}  // namespace cityatlas::atlas
