// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Rectangle packers for the atlas stage: decide where each texture goes in a
/// square atlas. Grid units are whatever the caller chooses (4x4-texel S3TC
/// blocks in practice), so a packed atlas never splits a compression block.

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace cityatlas::atlas {

enum class PackingMethod : uint8_t { IgarashiCosgrove, MaxRects };

std::string_view packingMethodName(PackingMethod m);  // "igarashi-cosgrove", "maxrects"
std::optional<PackingMethod> packingMethodFromName(std::string_view name);

/// One rectangle to place, in grid units (the caller packs in 4x4-texel S3TC blocks). w, h >= 1.
struct PackItem {
    int w = 0, h = 0;
};

/// Where an item went. Unrotated it covers [x, x+w) x [y, y+h); rotated (turned by 90 degrees) it covers
/// [x, x+h) x [y, y+w).
struct Placement {
    int x = 0, y = 0;
    bool rotated = false;
    friend bool operator==(const Placement&, const Placement&) = default;
};

/// Packs all items into a size x size square. Returns true and fills `out` (same order as items) when every item
/// fits; false otherwise (out unspecified). Deterministic: the same input gives the same output on every platform
/// and thread count (no hashing of pointers, no unstable sort without an index tie-break, no randomness).
/// An item with w or h below 1 makes it return false; an empty list fits any size.
///
/// IgarashiCosgrove: Igarashi & Cosgrove (2001) as Buchholz & Döllner describe it — all items turned portrait,
/// sorted by decreasing height, laid out in rows and pushed towards y = 0. MaxRects: Jylänki's MAXRECTS with
/// Best-Short-Side-Fit, rotation allowed, items in decreasing order of their longer side.
bool pack(PackingMethod method, std::span<const PackItem> items, int size, std::vector<Placement>* out);

/// The same into a width x height rectangle; `allow_rotation` false keeps every
/// item as given (IgarashiCosgrove then skips its portrait turn).
bool pack(PackingMethod method, std::span<const PackItem> items, int width, int height, bool allow_rotation,
          std::vector<Placement>* out);

struct BinSize {
    int w = 0, h = 0;
    friend bool operator==(const BinSize&, const BinSize&) = default;
};

/// Bins with sides multiples of `step` up to `max_w` x `max_h`, no side more
/// than `max_aspect` times the other, smallest area first (then the squarer,
/// then the wider): the order in which packSmallest tries them.
std::vector<BinSize> binsByArea(int step, int max_w, int max_h, double max_aspect);

/// Tries `candidates` in order, skipping those too small in area or side,
/// and returns the first whose packing holds every item (with `out` filled);
/// nullopt when none does. Deterministic like pack().
std::optional<BinSize> packSmallest(PackingMethod method, std::span<const PackItem> items,
                                    std::span<const BinSize> candidates, bool allow_rotation,
                                    std::vector<Placement>* out);

}  // namespace cityatlas::atlas
