// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/subdivide.h"

#include <algorithm>
#include <cmath>

namespace cityatlas::atlas {

namespace {

double centroid(const Triangle& t, int axis) {
    auto c = [&](const Vec3d& p) { return axis == 0 ? p.x : axis == 1 ? p.y : p.z; };
    return (c(t.position_local[0]) + c(t.position_local[1]) + c(t.position_local[2])) / 3.0;
}

// Cuts sorted `ids` in two non-empty parts with the first part's weight as
// close as possible to half of the total.
size_t balancedCut(const std::vector<uint32_t>& ids, std::span<const double> weight) {
    double total = 0;
    if (!weight.empty())
        for (uint32_t i : ids) total += weight[i];
    const bool by_count = !(total > 0);
    if (by_count) total = static_cast<double>(ids.size());
    double run = 0, best_gap = 1e300;
    size_t best = 1;
    for (size_t k = 1; k < ids.size(); ++k) {
        run += by_count ? 1.0 : weight[ids[k - 1]];
        const double gap = std::abs(run - 0.5 * total);
        if (gap < best_gap) best_gap = gap, best = k;
    }
    return best;
}

double coordinate(const Vec3d& p, int axis) { return axis == 0 ? p.x : axis == 1 ? p.y : p.z; }

template <class Key>
void sortAlong(std::vector<uint32_t>& ids, const Key& key, int axis) {
    std::vector<std::pair<double, uint32_t>> keyed;
    keyed.reserve(ids.size());
    for (uint32_t i : ids) keyed.emplace_back(key(i, axis), i);
    std::sort(keyed.begin(), keyed.end());
    for (size_t k = 0; k < ids.size(); ++k) ids[k] = keyed[k].second;
}

template <class Key>
std::array<std::vector<uint32_t>, 4> splitAlong(std::span<const uint32_t> ids, const Box3d& box, const Key& key,
                                                std::span<const double> weight) {
    std::array<std::vector<uint32_t>, 4> groups;
    if (ids.size() < 2) {
        groups[0].assign(ids.begin(), ids.end());
        return groups;
    }
    const std::array<double, 3> extent{box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z};
    std::array<int, 3> axes{0, 1, 2};
    std::stable_sort(axes.begin(), axes.end(), [&](int a, int b) { return extent[a] > extent[b]; });

    std::vector<uint32_t> all(ids.begin(), ids.end());
    sortAlong(all, key, axes[0]);
    const size_t cut = balancedCut(all, weight);
    std::array<std::vector<uint32_t>, 2> halves{std::vector<uint32_t>(all.begin(), all.begin() + cut),
                                                std::vector<uint32_t>(all.begin() + cut, all.end())};
    for (int h = 0; h < 2; ++h) {
        auto& half = halves[h];
        if (half.size() < 2) {
            groups[h] = std::move(half);
            continue;
        }
        sortAlong(half, key, axes[1]);
        const size_t c2 = balancedCut(half, weight);
        groups[h].assign(half.begin(), half.begin() + c2);
        groups[h + 2].assign(half.begin() + c2, half.end());
    }
    return groups;
}

}  // namespace

std::array<std::vector<uint32_t>, 4> splitIntoFour(std::span<const uint32_t> ids, std::span<const Triangle> triangles,
                                                   std::span<const double> weight) {
    Box3d box;
    for (uint32_t i : ids)
        for (const Vec3d& p : triangles[i].position_local) box.extend(p);
    return splitAlong(ids, box, [&](uint32_t i, int axis) { return centroid(triangles[i], axis); }, weight);
}

std::array<std::vector<uint32_t>, 4> splitIntoFourAt(std::span<const uint32_t> ids, std::span<const Vec3d> points,
                                                     std::span<const double> weight) {
    Box3d box;
    for (uint32_t i : ids) box.extend(points[i]);
    return splitAlong(ids, box, [&](uint32_t i, int axis) { return coordinate(points[i], axis); }, weight);
}

}  // namespace cityatlas::atlas
