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

// One candidate's estimate, summed one texture at a time in texture order
// (whether the models come all at once or a range at a time, the sums are
// the same to the bit).
class EstimateSum {
public:
    explicit EstimateSum(double d) : cell_(d / 4) { e_.d_m = d; }
    void add(const TextureModel& t, const TexturePlan& plan) {
        if (t.members.empty()) return;
        // BC1 half a byte per texel, BC3 one; mips add a third.
        e_.atlas_bytes += plan.region_texels * (t.channels == 4 ? 1.0 : 0.5) * 4.0 / 3.0 * kTreeOverRegions;
        e_.originals_used_bytes += t.original_bytes;
        if (plan.exact) return;
        e_.originals_needed_bytes += t.original_bytes;
        cells_[key(static_cast<int64_t>(std::floor(t.x / cell_)), static_cast<int64_t>(std::floor(t.y / cell_)))] +=
            t.original_bytes;
    }
    DminEstimate finish() const {
        DminEstimate e = e_;
        for (const auto& entry : cells_) {
            const int64_t cx = entry.first >> 32, cy = static_cast<int32_t>(entry.first & 0xffffffff);
            double sum = 0;
            for (int64_t dx = -4; dx <= 4; ++dx)
                for (int64_t dy = -4; dy <= 4; ++dy)
                    if (dx * dx + dy * dy <= 16)
                        if (const auto it = cells_.find(key(cx + dx, cy + dy)); it != cells_.end()) sum += it->second;
            e.originals_within_bytes = std::max(e.originals_within_bytes, sum);
        }
        e.ratio = e.originals_used_bytes > 0 ? (e.atlas_bytes + e.originals_needed_bytes) / e.originals_used_bytes : 0;
        return e;
    }

private:
    static int64_t key(int64_t cx, int64_t cy) { return (cx << 32) ^ (cy & 0xffffffff); }
    // Originals within d of a camera: their textures' centres binned in cells
    // of d/4; a camera in a cell reaches the cells whose centres lie within d
    // of its own (a disc of radius d, to a quarter cell).
    double cell_;
    std::unordered_map<int64_t, double> cells_;
    DminEstimate e_;
};

// Adds every model of `textures` to each sum, planning them at the sum's distance.
void addTo(std::vector<EstimateSum>& sums, const std::vector<double>& distances, const std::vector<TextureModel>& textures,
           const AtlasParams& params) {
    std::vector<TexturePlan> plans(textures.size());
    for (size_t c = 0; c < sums.size(); ++c) {
        tbb::parallel_for(size_t{0}, textures.size(),
                          [&](size_t i) { plans[i] = planTexture(textures[i], params, distances[c]); });
        for (size_t i = 0; i < textures.size(); ++i) sums[c].add(textures[i], plans[i]);
    }
}

// The candidate distances and the stop after the first accepted one, as one
// walk whichever way the estimates are made: next() gives the distance to
// estimate next (none once the walk has ended), take() the estimate made there.
class CandidateWalk {
public:
    CandidateWalk(const DminRange& range, double diagonal_m, std::function<bool(const DminEstimate&)> enough)
        : d_(range.lo), enough_(std::move(enough)) {
        // Beyond both, atlases keep shrinking (as 1/d^2) while the originals stay:
        // a few more octaves show where the ratio settles.
        hi_ = 16.0 * std::max({range.hi, diagonal_m, range.lo});
        done_ = range.lo >= 1e300;
    }
    bool done() const { return done_; }
    /// The next `n` distances to estimate (fewer at the end of the range).
    std::vector<double> next(size_t n) const {
        std::vector<double> out;
        for (double d = d_; out.size() < n; d *= std::sqrt(2.0)) {
            out.push_back(std::min(d, hi_));
            if (d >= hi_) break;
        }
        return out;
    }
    /// Takes the estimates of next()'s distances in order; the walk may end before the last.
    void take(const std::vector<DminEstimate>& estimates) {
        for (const DminEstimate& e : estimates) {
            if (done_) return;
            out_.push_back(e);
            if (after_enough_ < 0 && enough_ && enough_(e)) after_enough_ = kShownAfterTheChoice;
            if (d_ >= hi_ || after_enough_-- == 0) done_ = true;
            d_ *= std::sqrt(2.0);
        }
    }
    std::vector<DminEstimate> estimates() && { return std::move(out_); }

private:
    double d_, hi_ = 0;
    bool done_ = false;
    int after_enough_ = -1;  // candidates still to show once `enough` said yes
    std::function<bool(const DminEstimate&)> enough_;
    std::vector<DminEstimate> out_;
};

// Candidates estimated per pass over the batches: most choices end within
// the first few (the report shows three past the choice).
constexpr size_t kCandidatesPerRound = 8;

}  // namespace

void DminRange::add(const ChartMember& m, NativeSize native) {
    const double du = native.w > 0 ? m.per_u_1m / native.w : 0;
    const double dv = native.h > 0 ? m.per_v_1m / native.h : 0;
    const double least = std::min(du > 0 ? du : dv, dv > 0 ? dv : du);
    if (least > 0) lo = std::min(lo, least);
    hi = std::max({hi, du, dv});
}

std::vector<DminEstimate> estimateDminCandidates(const std::vector<TextureModel>& textures, double diagonal_m,
                                                 const AtlasParams& params,
                                                 const std::function<bool(const DminEstimate&)>& enough) {
    // Below `lo` every triangle's texture is capped on both axes, so nothing
    // changes; above `hi` every one is below its own resolution.
    DminRange range;
    for (const TextureModel& tm : textures)
        for (const ChartMember& m : tm.members) range.add(m, tm.native);
    CandidateWalk walk(range, diagonal_m, enough);
    while (!walk.done()) {
        const std::vector<double> d = walk.next(1);
        std::vector<EstimateSum> sums{EstimateSum(d[0])};
        addTo(sums, d, textures, params);
        walk.take({sums[0].finish()});
    }
    return std::move(walk).estimates();
}

Status estimateDminCandidatesInBatches(const DminRange& range, const ModelBatches& batches, double diagonal_m,
                                       const AtlasParams& params, const std::function<bool(const DminEstimate&)>& enough,
                                       std::vector<DminEstimate>* out) {
    CandidateWalk walk(range, diagonal_m, enough);
    while (!walk.done()) {
        const std::vector<double> d = walk.next(kCandidatesPerRound);
        std::vector<EstimateSum> sums;
        for (const double x : d) sums.emplace_back(x);
        if (Status s = batches([&](const std::vector<TextureModel>& models) { addTo(sums, d, models, params); }); !s.ok())
            return s;
        std::vector<DminEstimate> e;
        for (const EstimateSum& sum : sums) e.push_back(sum.finish());
        walk.take(e);
    }
    *out = std::move(walk).estimates();
    return Status::Ok();
}

namespace {

std::function<bool(const DminEstimate&)> qualifiesBy(const DminRule& rule) {
    return [limit = rule.originals_within_mb * 1e6, target = rule.ratio_target](const DminEstimate& e) {
        return e.originals_within_bytes <= limit && e.ratio <= target;
    };
}

DminChoice chooseFrom(const std::vector<DminEstimate>& c, double diagonal, const AtlasParams& params, double* d_min_m,
                      const DminRule& rule) {
    const double limit = rule.originals_within_mb * 1e6;
    const auto qualifies = qualifiesBy(rule);
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

}  // namespace

DminChoice chooseDefaultDmin(const std::vector<TextureModel>& textures, double diagonal, const AtlasParams& params,
                             double* d_min_m, const DminRule& rule) {
    return chooseFrom(estimateDminCandidates(textures, diagonal, params, qualifiesBy(rule)), diagonal, params, d_min_m,
                      rule);
}

Status chooseDefaultDminInBatches(const DminRange& range, const ModelBatches& batches, double diagonal,
                                  const AtlasParams& params, double* d_min_m, DminChoice* choice, const DminRule& rule) {
    std::vector<DminEstimate> c;
    if (Status s = estimateDminCandidatesInBatches(range, batches, diagonal, params, qualifiesBy(rule), &c); !s.ok())
        return s;
    *choice = chooseFrom(c, diagonal, params, d_min_m, rule);
    return Status::Ok();
}

}  // namespace cityatlas::atlas
