// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/input_overlap.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include <fmt/format.h>

namespace cityatlas {

void OverlapWatch::beginFile(const std::string& path) { files_.push_back(path); }

uint32_t OverlapWatch::addFeature(Feature f) {
    const uint32_t file = files_.empty() ? 0 : static_cast<uint32_t>(files_.size() - 1);
    // Building parts count with their building (the parent was added before them).
    const bool part = f.parent >= 0 && static_cast<size_t>(f.parent) < building_of_.size();
    const uint32_t building = part ? building_of_[static_cast<size_t>(f.parent)] : static_cast<uint32_t>(buildings_.size());
    if (!part)
        buildings_.push_back({.id_hash = std::hash<std::string>{}(f.gml_id), .file = file, .has_id = !f.gml_id.empty()});
    const uint32_t index = inner_.addFeature(std::move(f));
    if (building_of_.size() <= index) building_of_.resize(index + 1, 0);
    building_of_[index] = building;
    return index;
}

void OverlapWatch::addTriangles(std::vector<Triangle>& triangles) {
    for (const Triangle& t : triangles) {
        if (t.feature >= building_of_.size()) continue;
        Building& b = buildings_[building_of_[t.feature]];
        for (const Vec3d& p : t.position_local) {
            const auto x = static_cast<float>(p.x), y = static_cast<float>(p.y);
            b.min_x = std::min(b.min_x, x), b.max_x = std::max(b.max_x, x);
            b.min_y = std::min(b.min_y, y), b.max_y = std::max(b.max_y, y);
        }
    }
    inner_.addTriangles(triangles);
}

namespace {
constexpr double kSameIdDistance_m = 50.0;  // centres of two copies of one building, at most
}

bool OverlapWatch::near(const Building& a, const Building& b) {
    if (a.min_x > a.max_x || b.min_x > b.max_x) return false;
    const double dx = (double{a.min_x} + a.max_x - b.min_x - b.max_x) / 2,
                 dy = (double{a.min_y} + a.max_y - b.min_y - b.max_y) / 2;
    return dx * dx + dy * dy <= kSameIdDistance_m * kSameIdDistance_m;
}

void OverlapWatch::report(Diagnostics& diagnostics) const {
    if (files_.size() < 2) return;
    std::vector<uint64_t> per_file(files_.size(), 0);
    for (const Building& b : buildings_) per_file[b.file]++;

    // Shared buildings per pair of files (first file, later file).
    std::map<std::pair<uint32_t, uint32_t>, uint64_t> by_id, by_footprint;
    // The same gml:id counts where the two lie near each other: numbered ids
    // ("BLDG_1") repeat across tiles of other places.
    std::unordered_map<uint64_t, uint32_t> first_with_id;
    for (uint32_t i = 0; i < buildings_.size(); ++i) {
        const Building& b = buildings_[i];
        if (!b.has_id) continue;
        auto [it, inserted] = first_with_id.emplace(b.id_hash, i);
        const Building& o = buildings_[it->second];
        if (!inserted && o.file != b.file && near(o, b)) by_id[{o.file, b.file}]++;
    }
    // Footprint boxes hashed by their centre on a grid of the tolerance; a
    // match is in the same or a neighbouring cell with every edge within it.
    auto cell = [](double v) { return static_cast<int64_t>(std::floor(v / kOverlapTolerance_m)); };
    std::unordered_map<uint64_t, std::vector<uint32_t>> grid;
    auto key = [](int64_t x, int64_t y) { return (static_cast<uint64_t>(x) * 0x9E3779B97F4A7C15ull) ^ static_cast<uint64_t>(y); };
    for (uint32_t i = 0; i < buildings_.size(); ++i) {
        const Building& b = buildings_[i];
        if (b.min_x > b.max_x) continue;  // no geometry
        const int64_t cx = cell((double{b.min_x} + b.max_x) / 2), cy = cell((double{b.min_y} + b.max_y) / 2);
        std::vector<uint32_t> matched_files;  // each other file once per building
        for (int64_t dx = -1; dx <= 1; ++dx)
            for (int64_t dy = -1; dy <= 1; ++dy) {
                auto it = grid.find(key(cx + dx, cy + dy));
                if (it == grid.end()) continue;
                for (uint32_t j : it->second) {
                    const Building& o = buildings_[j];
                    if (o.file == b.file ||
                        std::find(matched_files.begin(), matched_files.end(), o.file) != matched_files.end())
                        continue;
                    const auto within = [](float u, float v) { return std::abs(double{u} - v) <= kOverlapTolerance_m; };
                    if (within(o.min_x, b.min_x) && within(o.max_x, b.max_x) && within(o.min_y, b.min_y) &&
                        within(o.max_y, b.max_y)) {
                        by_footprint[{o.file, b.file}]++;
                        matched_files.push_back(o.file);
                    }
                }
            }
        grid[key(cx, cy)].push_back(i);
    }

    std::map<std::pair<uint32_t, uint32_t>, std::pair<uint64_t, uint64_t>> pairs;  // (ids, footprints)
    for (const auto& [p, n] : by_id) pairs[p].first = n;
    for (const auto& [p, n] : by_footprint) pairs[p].second = n;
    for (const auto& [p, n] : pairs) {
        const uint64_t smaller = std::min(per_file[p.first], per_file[p.second]);
        const uint64_t shared = std::max(n.first, n.second);
        if (smaller == 0 || static_cast<double>(shared) < kOverlapShare * static_cast<double>(smaller)) continue;
        diagnostics.warn(warn::kInputsOverlap,
                         {files_[p.second], 0, "",
                          fmt::format("{} of its {} buildings are also in {} ({} by gml:id, {} by footprint within {} m): "
                                      "they are read twice and drawn twice; pass only one of the two files",
                                      shared, per_file[p.second], files_[p.first], n.first, n.second, kOverlapTolerance_m)});
    }
}

}  // namespace cityatlas
