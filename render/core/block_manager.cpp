// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/core/block_manager.h"

#include <algorithm>

#include <fmt/format.h>

namespace cityatlas::render {

BlockManager::BlockManager(const TilesetIndex& index, const BudgetParams& params)
    : index_(index),
      params_(params),
      state_(index.blocks.size(), BlockState::Absent),
      in_ideal_(index.blocks.size(), 0),
      retry_from_update_(index.blocks.size(), 0),
      failures_(index.blocks.size(), 0) {}

Status BlockManager::checkBudget(const TilesetIndex& index, uint64_t budget_bytes) {
    uint64_t root = 0;
    forEachRootBlock(index, [&](BlockId b) { root += index.blocks[b].bytes; });
    if (root > budget_bytes)
        return Status::Invalid(fmt::format("memory budget {} bytes is smaller than the root's blocks ({} bytes), which are "
                                        "always resident; give at least {} bytes",
                                        budget_bytes, root, root));
    return Status::Ok();
}

BlockActions BlockManager::update(const Classification& c) {
    BlockActions actions;
    const size_t n = index_.blocks.size();
    auto bytes = [&](BlockId b) { return index_.blocks[b].bytes; };
    ++updates_;
    // Transient failures whose cool-down is over become candidates again.
    for (BlockId b = 0; b < n; ++b)
        if (state_[b] == BlockState::Failed && retry_from_update_[b] != 0 && updates_ >= retry_from_update_[b]) {
            state_[b] = BlockState::Absent;
            retry_from_update_[b] = 0;
        }

    // The ideal block set: the longest prefix of the candidates that fits.
    std::fill(in_ideal_.begin(), in_ideal_.end(), 0);
    ideal_.clear();
    uint64_t ideal_bytes = 0;
    stats_.ideal_cut = false;
    for (const BlockId b : c.candidates) {
        if (state_[b] == BlockState::Failed) continue;
        if (ideal_bytes + bytes(b) > params_.budget_bytes) {
            stats_.ideal_cut = true;
            break;
        }
        ideal_bytes += bytes(b);
        ideal_.push_back(b);
        in_ideal_[b] = 1;
    }

    // Requests that left the ideal set are cancelled.
    uint64_t resident = 0, requested = 0;
    uint32_t requested_count = 0;
    for (BlockId b = 0; b < n; ++b) {
        if (state_[b] == BlockState::Requested && !in_ideal_[b]) {
            state_[b] = BlockState::Absent;
            actions.cancel.push_back(b);
            ++stats_.cancellations;
        }
        if (state_[b] == BlockState::Resident) resident += bytes(b);
        if (state_[b] == BlockState::Requested) {
            requested += bytes(b);
            ++requested_count;
        }
    }

    // Eviction candidates: resident blocks outside the ideal set, lowest priority last in the list
    // (popped first). Built only when needed.
    std::vector<BlockId> evictable;
    bool evictable_built = false;
    auto evictOne = [&]() -> bool {
        if (!evictable_built) {
            for (BlockId b = 0; b < n; ++b)
                if (state_[b] == BlockState::Resident && !in_ideal_[b]) evictable.push_back(b);
            std::sort(evictable.begin(), evictable.end(),
                      [&](BlockId a, BlockId b) { return before(c.priority[a], a, c.priority[b], b); });
            evictable_built = true;
        }
        if (evictable.empty()) return false;
        const BlockId victim = evictable.back();
        evictable.pop_back();
        state_[victim] = BlockState::Absent;
        resident -= bytes(victim);
        actions.evict.push_back(victim);
        ++stats_.evictions;
        return true;
    };
    // A lowered budget: shrink right away.
    while (resident + requested > params_.budget_bytes && evictOne()) {
    }

    // Fill the bounded queue from the ideal set, in priority order.
    for (const BlockId b : ideal_) {
        if (requested_count >= params_.max_requests) break;
        if (state_[b] != BlockState::Absent) continue;
        bool room = true;
        while (resident + requested + bytes(b) > params_.budget_bytes) {
            if (!evictOne()) {
                room = false;
                break;
            }
        }
        if (!room) break;  // cannot happen while the ideal set fits; stop rather than overflow
        state_[b] = BlockState::Requested;
        requested += bytes(b);
        ++requested_count;
        actions.request.push_back(b);
    }

    // Statistics.
    stats_.resident_bytes = resident;
    stats_.requested_bytes = requested;
    stats_.requested_blocks = requested_count;
    stats_.resident_blocks = 0;
    stats_.failed_blocks = 0;
    for (BlockId b = 0; b < n; ++b) {
        stats_.resident_blocks += state_[b] == BlockState::Resident ? 1 : 0;
        stats_.failed_blocks += state_[b] == BlockState::Failed ? 1 : 0;
    }
    stats_.ideal_blocks = static_cast<uint32_t>(ideal_.size());
    stats_.ideal_bytes = ideal_bytes;
    stats_.ideal_missing = 0;
    stats_.needed_missing = 0;
    stats_.needed_bytes = 0;
    for (const BlockId b : ideal_) {
        if (c.priority[b].usage == Usage::Needed) stats_.needed_bytes += bytes(b);
        if (state_[b] == BlockState::Resident) continue;
        ++stats_.ideal_missing;
        if (c.priority[b].usage == Usage::Needed) ++stats_.needed_missing;
    }
    return actions;
}

bool BlockManager::finished(BlockId id, bool ok, bool transient) {
    if (id >= state_.size() || state_[id] != BlockState::Requested) return false;
    const uint64_t b = index_.blocks[id].bytes;
    state_[id] = ok ? BlockState::Resident : BlockState::Failed;
    if (ok) {
        failures_[id] = 0;
    } else if (transient) {
        const uint32_t shift = std::min<uint32_t>(failures_[id], 6);  // 8 << 6 = 512
        retry_from_update_[id] = updates_ + std::min(kMaxFailureCooldownUpdates, kFailureCooldownUpdates << shift);
        if (failures_[id] < UINT16_MAX) ++failures_[id];
    }
    stats_.requested_bytes -= std::min(stats_.requested_bytes, b);
    if (stats_.requested_blocks) --stats_.requested_blocks;
    if (ok) {
        stats_.resident_bytes += b;
        ++stats_.resident_blocks;
    } else {
        ++stats_.failed_blocks;
    }
    // The ideal set's completeness changes as blocks arrive.
    if (in_ideal_[id] && stats_.ideal_missing) {
        --stats_.ideal_missing;
        // needed_missing is recomputed at the next update(); keep it conservative here.
    }
    return true;
}

}  // namespace cityatlas::render
