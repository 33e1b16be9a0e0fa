// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/input_overlap.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>

#include "core/external_sort.h"

#include <fmt/format.h>

namespace cityatlas {

void OverlapWatch::beginFile(const std::string& path) { files_.push_back(path); }

uint32_t OverlapWatch::addFeature(Feature f) {
    const uint32_t file = files_.empty() ? 0 : static_cast<uint32_t>(files_.size() - 1);
    // Building parts count with their building (the parent was added before them).
    const bool part = f.parent >= 0 && static_cast<size_t>(f.parent) < building_of_.size();
    const uint32_t building =
        part ? building_of_.get(static_cast<size_t>(f.parent)) : static_cast<uint32_t>(building_count_);
    if (!part) {
        buildings_.at(building_count_++) = {
            .id_hash = std::hash<std::string>{}(f.gml_id), .file = file, .has_id = !f.gml_id.empty()};
    }
    const uint32_t index = inner_.addFeature(std::move(f));
    building_of_.at(index) = building;
    return index;
}

void OverlapWatch::addTriangles(std::vector<Triangle>& triangles) {
    for (const Triangle& t : triangles) {
        if (t.feature >= building_of_.size()) continue;
        Building& b = buildings_.at(building_of_.get(t.feature));
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

// Pairs of files (first file, later file) -> buildings they share.
using PairCounts = std::map<std::pair<uint32_t, uint32_t>, uint64_t>;

// A building in the order of its id's hash, with what the comparison needs
// (so the sorted pass looks nothing up).
struct ById {
    uint64_t id_hash = 0;
    uint32_t index = 0, file = 0;
    float min_x = 0, min_y = 0, max_x = 0, max_y = 0;
    bool operator<(const ById& o) const { return id_hash != o.id_hash ? id_hash < o.id_hash : index < o.index; }
};

bool near(const ById& a, const ById& b) {
    if (a.min_x > a.max_x || b.min_x > b.max_x) return false;  // no geometry
    const double dx = (double{a.min_x} + a.max_x - b.min_x - b.max_x) / 2,
                 dy = (double{a.min_y} + a.max_y - b.min_y - b.max_y) / 2;
    return dx * dx + dy * dy <= kSameIdDistance_m * kSameIdDistance_m;
}

// A building in the order of its ground plan's cell: rows (y), then columns (x).
struct ByCell {
    int64_t row = 0, column = 0;
    uint32_t index = 0, file = 0;
    float min_x = 0, min_y = 0, max_x = 0, max_y = 0;
    bool operator<(const ByCell& o) const {
        return row != o.row ? row < o.row : column != o.column ? column < o.column : index < o.index;
    }
};

// Footprint boxes by their centre on a grid of the tolerance: two boxes with
// every edge within it have centres in the same or a neighbouring cell.
int64_t cellOf(double v) { return static_cast<int64_t>(std::floor(v / kOverlapTolerance_m)); }

// The same gml:id counts where the two lie near each other (numbered ids,
// "BLDG_1", repeat across tiles of other places): each building against the
// first one with its id.
Status sharedById(ExternalSorter<ById>& sorter, PairCounts* by_id) {
    ById first;
    bool any = false;
    return sorter.forEachSorted([&](const ById& b) {
        if (!any || b.id_hash != first.id_hash) {
            first = b;
            any = true;
            return;
        }
        if (first.file != b.file && near(first, b)) (*by_id)[{first.file, b.file}]++;
    });
}

// Each building against the earlier ones (lower index) of another file whose
// box matches within the tolerance, each other file once: the cells in
// sorted order, a row of cells (1 m) at a time, three rows in memory.
Status sharedByFootprint(ExternalSorter<ByCell>& sorter, PairCounts* by_footprint) {
    struct Row {
        int64_t row = 0;
        std::vector<ByCell> cells;  // by column, then index
        bool done = false;
    };
    std::deque<Row> rows;  // complete rows, ascending
    Row building;          // the row being read (its cells come in order)
    bool started = false;
    const auto within = [](float u, float v) { return std::abs(double{u} - v) <= kOverlapTolerance_m; };
    auto processRow = [&](Row& r) {
        std::vector<uint32_t> matched_files;
        for (const ByCell& b : r.cells) {
            matched_files.clear();
            for (const Row& q : rows) {
                if (q.row < r.row - 1 || q.row > r.row + 1) continue;
                auto it = std::lower_bound(q.cells.begin(), q.cells.end(), b.column - 1,
                                           [](const ByCell& c, int64_t column) { return c.column < column; });
                for (; it != q.cells.end() && it->column <= b.column + 1; ++it) {
                    const ByCell& o = *it;
                    if (o.index >= b.index || o.file == b.file ||
                        std::find(matched_files.begin(), matched_files.end(), o.file) != matched_files.end())
                        continue;
                    if (within(o.min_x, b.min_x) && within(o.max_x, b.max_x) && within(o.min_y, b.min_y) &&
                        within(o.max_y, b.max_y)) {
                        (*by_footprint)[{o.file, b.file}]++;
                        matched_files.push_back(o.file);
                    }
                }
            }
        }
        r.done = true;
    };
    // Once row `next` is being read, the rows below next - 1 have both
    // neighbours complete: compared, then the ones no row left to compare
    // needs let go.
    auto processBelow = [&](int64_t next, bool end) {
        for (Row& r : rows)
            if (!r.done && (end || r.row + 1 < next)) processRow(r);
        while (!rows.empty() && rows.front().done &&
               (rows.size() < 2 || rows[1].done || rows[1].row > rows.front().row + 1))
            rows.pop_front();
    };
    Status s = sorter.forEachSorted([&](const ByCell& c) {
        if (started && c.row != building.row) {
            rows.push_back(std::move(building));
            building = Row{};
            processBelow(c.row, false);
        }
        started = true;
        building.row = c.row;
        building.cells.push_back(c);
    });
    if (!s.ok()) return s;
    if (started) rows.push_back(std::move(building));
    processBelow(0, true);
    return Status::Ok();
}

}  // namespace

Status OverlapWatch::report(Diagnostics& diagnostics) {
    if (files_.size() < 2) return Status::Ok();
    // One pass over the buildings (in order: the file a block at a time)
    // counts them per file and feeds both sorts.
    std::vector<uint64_t> per_file(files_.size(), 0);
    ExternalSorter<ById> ids(scratch_dir_, sort_bytes_);
    ExternalSorter<ByCell> cells(scratch_dir_, sort_bytes_);
    for (size_t i = 0; i < building_count_; ++i) {
        const Building b = buildings_.get(i);
        per_file[b.file]++;
        const auto index = static_cast<uint32_t>(i);
        if (b.has_id)
            if (Status s = ids.push({b.id_hash, index, b.file, b.min_x, b.min_y, b.max_x, b.max_y}); !s.ok()) return s;
        if (b.min_x > b.max_x) continue;  // no geometry
        if (Status s = cells.push({cellOf((double{b.min_y} + b.max_y) / 2), cellOf((double{b.min_x} + b.max_x) / 2),
                                   index, b.file, b.min_x, b.min_y, b.max_x, b.max_y});
            !s.ok())
            return s;
    }
    PairCounts by_id, by_footprint;
    if (Status s = sharedById(ids, &by_id); !s.ok()) return s;
    if (Status s = sharedByFootprint(cells, &by_footprint); !s.ok()) return s;
    if (!buildings_.status().ok()) return buildings_.status();
    if (!building_of_.status().ok()) return building_of_.status();

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
    return Status::Ok();
}

}  // namespace cityatlas
