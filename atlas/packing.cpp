// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/packing.h"

#include <algorithm>
#include <cstddef>
#include <numeric>
#include <tuple>

namespace cityatlas::atlas {
namespace {

struct Rect {
    int x = 0, y = 0, w = 0, h = 0;
};

// Rejects before any packing work: a caller probing many atlas sizes should pay
// almost nothing for the hopeless ones.
bool obviouslyUnpackable(std::span<const PackItem> items, int width, int height, bool allow_rotation) {
    int64_t area = 0;
    for (const PackItem& it : items) {
        if (it.w < 1 || it.h < 1) return true;
        const bool fits = (it.w <= width && it.h <= height) || (allow_rotation && it.h <= width && it.w <= height);
        if (!fits) return true;
        area += int64_t{it.w} * it.h;
    }
    return area > int64_t{width} * height;
}

// Every sort below ends its key in the input index, so std::sort (unstable) still
// yields one order on every standard library.
std::vector<size_t> identityOrder(size_t n) {
    std::vector<size_t> order(n);
    std::iota(order.begin(), order.end(), size_t{0});
    return order;
}

bool packIgarashiCosgrove(std::span<const PackItem> items, int width, int height, bool allow_rotation,
                          std::vector<Placement>& out) {
    struct Portrait {
        int w, h;
        bool rotated;
    };
    std::vector<Portrait> p(items.size());
    for (size_t i = 0; i < items.size(); ++i) {
        const bool rot = allow_rotation && items[i].w > items[i].h;
        p[i] = rot ? Portrait{items[i].h, items[i].w, true} : Portrait{items[i].w, items[i].h, false};
    }
    std::vector<size_t> order = identityOrder(items.size());
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        return std::tie(p[b].h, p[b].w, a) < std::tie(p[a].h, p[a].w, b);
    });

    // Rectangles arrive from above in row order, so the first thing a falling
    // rectangle meets is the highest top edge under its span: a per-column
    // height map is exact, not an approximation.
    std::vector<int> skyline(static_cast<size_t>(width), 0);
    int cursor = 0;
    for (size_t i : order) {
        const Portrait& r = p[i];
        if (r.w > width) return false;
        if (cursor + r.w > width) cursor = 0;
        const auto first = skyline.begin() + cursor;
        const auto last = first + r.w;
        const int y = *std::max_element(first, last);
        if (y + r.h > height) return false;
        std::fill(first, last, y + r.h);
        out[i] = Placement{cursor, y, r.rotated};
        cursor += r.w;
    }
    return true;
}

bool overlaps(const Rect& a, const Rect& b) {
    return a.x < b.x + b.w && b.x < a.x + a.w && a.y < b.y + b.h && b.y < a.y + a.h;
}

bool contains(const Rect& outer, const Rect& inner) {
    return inner.x >= outer.x && inner.y >= outer.y && inner.x + inner.w <= outer.x + outer.w &&
           inner.y + inner.h <= outer.y + outer.h;
}

class MaxRectsBin {
public:
    MaxRectsBin(int width, int height, bool allow_rotation) : allow_rotation_(allow_rotation) {
        free_.push_back(Rect{0, 0, width, height});
    }

    /// Places a w x h item (or h x w); false when no free rectangle can take it either way.
    bool insert(int w, int h, Placement* where) {
        using Score = std::tuple<int, int, int, int, bool>;  // short leftover, long leftover, y, x, rotated
        bool found = false;
        Score best{};
        Rect bestRect;
        auto consider = [&](const Rect& f, int pw, int ph, bool rotated) {
            if (pw > f.w || ph > f.h) return;
            const int dw = f.w - pw, dh = f.h - ph;
            const Score s{std::min(dw, dh), std::max(dw, dh), f.y, f.x, rotated};
            if (!found || s < best) {
                found = true;
                best = s;
                bestRect = Rect{f.x, f.y, pw, ph};
            }
        };
        for (const Rect& f : free_) {
            consider(f, w, h, false);
            // A square turned round has the same footprint; reporting it unrotated keeps the output canonical.
            if (w != h && allow_rotation_) consider(f, h, w, true);
        }
        if (!found) return false;
        *where = Placement{bestRect.x, bestRect.y, std::get<4>(best)};
        carve(bestRect);
        return true;
    }

private:
    void carve(const Rect& used) {
        pieces_.clear();
        size_t kept = 0;
        for (size_t i = 0; i < free_.size(); ++i) {
            const Rect f = free_[i];
            if (!overlaps(f, used)) {
                free_[kept++] = f;
                continue;
            }
            // The (up to) four maximal free rectangles left around `used`; they overlap each other by design.
            if (used.x > f.x) pieces_.push_back(Rect{f.x, f.y, used.x - f.x, f.h});
            if (used.x + used.w < f.x + f.w)
                pieces_.push_back(Rect{used.x + used.w, f.y, f.x + f.w - (used.x + used.w), f.h});
            if (used.y > f.y) pieces_.push_back(Rect{f.x, f.y, f.w, used.y - f.y});
            if (used.y + used.h < f.y + f.h)
                pieces_.push_back(Rect{f.x, used.y + used.h, f.w, f.y + f.h - (used.y + used.h)});
        }
        free_.resize(kept);

        // The untouched rectangles were already free of mutual containment, and
        // none of them can lie inside a new piece (that piece's parent would have
        // contained it too), so only the new pieces need checking: against the
        // survivors and against one another. This keeps pruning O(new * free)
        // instead of O(free^2) per item.
        const size_t oldCount = free_.size();
        for (size_t i = 0; i < pieces_.size(); ++i) {
            const Rect& n = pieces_[i];
            bool redundant = false;
            for (size_t j = 0; j < oldCount && !redundant; ++j) redundant = contains(free_[j], n);
            for (size_t j = 0; j < pieces_.size() && !redundant; ++j) {
                if (j == i) continue;
                const Rect& m = pieces_[j];
                // Of two identical pieces keep the earlier one, so exactly one survives.
                const bool same = m.x == n.x && m.y == n.y && m.w == n.w && m.h == n.h;
                redundant = same ? j < i : contains(m, n);
            }
            if (!redundant) free_.push_back(n);
        }
    }

    bool allow_rotation_ = true;
    std::vector<Rect> free_;
    std::vector<Rect> pieces_;  // scratch, kept to avoid an allocation per item
};

bool packMaxRects(std::span<const PackItem> items, int width, int height, bool allow_rotation,
                  std::vector<Placement>& out) {
    std::vector<size_t> order = identityOrder(items.size());
    auto key = [&](size_t i) {
        return std::make_tuple(std::max(items[i].w, items[i].h), int64_t{items[i].w} * items[i].h);
    };
    // Offline order: big items first while the bin still has large free areas.
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        const auto ka = key(a), kb = key(b);
        if (ka != kb) return kb < ka;
        return a < b;
    });
    MaxRectsBin bin(width, height, allow_rotation);
    for (size_t i : order)
        if (!bin.insert(items[i].w, items[i].h, &out[i])) return false;
    return true;
}

}  // namespace

std::string_view packingMethodName(PackingMethod m) {
    switch (m) {
        case PackingMethod::IgarashiCosgrove: return "igarashi-cosgrove";
        case PackingMethod::MaxRects: return "maxrects";
    }
    return "unknown";
}

std::optional<PackingMethod> packingMethodFromName(std::string_view name) {
    for (PackingMethod m : {PackingMethod::IgarashiCosgrove, PackingMethod::MaxRects})
        if (packingMethodName(m) == name) return m;
    return std::nullopt;
}

bool pack(PackingMethod method, std::span<const PackItem> items, int size, std::vector<Placement>* out) {
    return pack(method, items, size, size, true, out);
}

bool pack(PackingMethod method, std::span<const PackItem> items, int width, int height, bool allow_rotation,
          std::vector<Placement>* out) {
    if (items.empty()) {
        if (out) out->clear();
        return true;
    }
    if (width < 1 || height < 1 || obviouslyUnpackable(items, width, height, allow_rotation)) return false;
    std::vector<Placement> scratch;
    std::vector<Placement>& result = out ? *out : scratch;
    result.assign(items.size(), Placement{});
    switch (method) {
        case PackingMethod::IgarashiCosgrove: return packIgarashiCosgrove(items, width, height, allow_rotation, result);
        case PackingMethod::MaxRects: return packMaxRects(items, width, height, allow_rotation, result);
    }
    return false;
}

std::vector<BinSize> binsByArea(int step, int max_w, int max_h, double max_aspect) {
    std::vector<BinSize> bins;
    if (step < 1) return bins;
    for (int w = step; w <= max_w; w += step)
        for (int h = step; h <= max_h; h += step)
            if (std::max(w, h) <= max_aspect * std::min(w, h)) bins.push_back({w, h});
    std::sort(bins.begin(), bins.end(), [](const BinSize& a, const BinSize& b) {
        return std::make_tuple(int64_t{a.w} * a.h, std::max(a.w, a.h), -a.w) <
               std::make_tuple(int64_t{b.w} * b.h, std::max(b.w, b.h), -b.w);
    });
    return bins;
}

std::optional<BinSize> packSmallest(PackingMethod method, std::span<const PackItem> items,
                                    std::span<const BinSize> candidates, bool allow_rotation,
                                    std::vector<Placement>* out) {
    for (const BinSize& b : candidates)
        if (pack(method, items, b.w, b.h, allow_rotation, out)) return b;
    return std::nullopt;
}

}  // namespace cityatlas::atlas
