// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The RAM level below the GPU budget (papers/004 §4.2, Hesina et al.): block
/// bytes as fetched, kept after the GPU lets a block go, so that coming back
/// to a view costs a decode, not a transfer. Every block is stamped with the
/// last frame it was in the ideal set (the paper's timestamp per use), and
/// the least recently used go first (ties: the larger block id, deeper in
/// the tree) whenever a new one would pass the RAM budget. Invariant: the
/// bytes held never exceed the budget; a block larger than the whole budget
/// is not kept. Plain data and no locking: the loader guards it.

#include <cstdint>
#include <map>
#include <set>
#include <utility>
#include <vector>

#include "render/core/tileset_index.h"

namespace cityatlas::render {

class ByteCache {
public:
    explicit ByteCache(uint64_t budget_bytes = 0) : budget_(budget_bytes) {}

    /// Copies the block's bytes into *out and counts a hit; false when it is not held.
    bool get(BlockId id, std::vector<uint8_t>* out);
    /// Keeps the bytes (stamped with the current frame), evicting the least
    /// recently used until they fit; not kept when larger than the budget.
    void put(BlockId id, std::vector<uint8_t> bytes);
    /// The blocks of this frame's ideal set: those held get `frame` as their
    /// stamp; later put()s are stamped with it too. Frames only grow.
    void touch(const std::vector<BlockId>& ideal, uint64_t frame);

    uint64_t bytes() const { return bytes_; }
    uint64_t budget() const { return budget_; }
    uint64_t hits() const { return hits_; }
    size_t blocks() const { return entries_.size(); }
    bool holds(BlockId id) const { return entries_.count(id) > 0; }

private:
    struct Entry {
        std::vector<uint8_t> bytes;
        uint64_t stamp = 0;
    };
    void evictFor(uint64_t incoming);

    uint64_t budget_ = 0;
    uint64_t bytes_ = 0;
    uint64_t hits_ = 0;
    uint64_t frame_ = 0;
    std::map<BlockId, Entry> entries_;
    std::set<std::pair<uint64_t, int64_t>> order_;  ///< (stamp, -id): the first is evicted first
};

}  // namespace cityatlas::render
