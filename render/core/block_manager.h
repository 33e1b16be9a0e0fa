// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The memory budget over blocks (papers/000 §4.6): each frame the ideal block
/// set is the longest prefix of the classification's candidates (priority
/// order, root pinned first) whose summed bytes fit the budget; a bounded
/// request queue is filled from it in priority order; a request that leaves
/// the ideal set is cancelled; when a new request would overflow the budget,
/// resident blocks outside the ideal set are evicted, lowest priority first.
///
/// Budget invariant: resident bytes + bytes of requests in flight never exceed
/// the budget, so residency stays within it whatever order loads finish in.
/// A block that failed to load is not requested again in this session and is
/// left out of the ideal set (its node simply stays coarser).
///
/// Why ancestors stay resident: a node's parent always precedes it in priority
/// order (a Needed, Culled or Parent-needed node has a Needed parent, at no
/// greater distance and a lower level), so the ideal set is closed under
/// ancestors and evictions take children before their parents. The exception
/// is transient: loads finish out of order, so a child may arrive a few frames
/// before its parent; selectDraws never draws it before the parent is drawable.

#include <cstdint>
#include <vector>

#include "render/core/selection.h"
#include "render/core/tileset_index.h"

namespace cityatlas::render {

enum class BlockState : uint8_t { Absent, Requested, Resident, Failed };

struct BudgetParams {
    uint64_t budget_bytes = 512ull << 20;  ///< summed block sizes (as tileset.json gives them)
    uint32_t max_requests = 16;            ///< requests in flight at most (the bounded queue)
};

/// What the caller must do after update(): hand requests to the loader,
/// cancel requests, and free evicted blocks (GPU memory).
struct BlockActions {
    std::vector<BlockId> request, cancel, evict;
};

struct BudgetStats {
    uint64_t resident_bytes = 0, requested_bytes = 0;
    uint32_t resident_blocks = 0, requested_blocks = 0, failed_blocks = 0;
    uint32_t ideal_blocks = 0, ideal_missing = 0;   ///< in the ideal set; of those not resident
    uint32_t needed_missing = 0;                    ///< Needed blocks of the ideal set not resident
    uint64_t ideal_bytes = 0;
    uint64_t needed_bytes = 0;                      ///< of the ideal set, its Needed blocks (what the frame shows)
    bool ideal_cut = false;                         ///< the budget cut the candidate list short
    uint64_t evictions = 0, cancellations = 0;      ///< since start
};

class BlockManager {
public:
    BlockManager(const TilesetIndex& index, const BudgetParams& params);

    /// The root's blocks alone must fit the budget; else an error naming both sizes.
    static Status checkBudget(const TilesetIndex& index, uint64_t budget_bytes);

    /// Plans this frame from a fresh classification: updates the ideal set,
    /// marks cancelled requests Absent, evicted blocks Absent, new requests
    /// Requested, and returns the actions.
    BlockActions update(const Classification& classification);

    /// A requested block finished: Resident (ok) or Failed. Ignored for a
    /// block that is no longer Requested (cancelled meanwhile); returns false then,
    /// and the caller drops the data. A `transient` failure (a 5xx, a reset, a
    /// timeout, a short body: the loader's own retries ran out) is tried again
    /// after a cool-down of kFailureCooldownUpdates updates, doubling with each
    /// further failure of the block up to kMaxFailureCooldownUpdates: so the
    /// ideal set is complete again once a flaky server recovers. A permanent
    /// one (404, bytes that do not decode) stays Failed.
    bool finished(BlockId id, bool ok, bool transient = false);
    static constexpr uint32_t kFailureCooldownUpdates = 8;
    static constexpr uint32_t kMaxFailureCooldownUpdates = 512;

    void setBudget(uint64_t budget_bytes) { params_.budget_bytes = budget_bytes; }
    void setMaxRequests(uint32_t n) { params_.max_requests = n; }
    const BudgetParams& params() const { return params_; }

    BlockState state(BlockId id) const { return state_[id]; }
    bool resident(BlockId id) const { return state_[id] == BlockState::Resident; }
    /// Failed and never tried again: a permanent failure (a transient one
    /// waits out its cool-down and becomes a candidate again).
    bool failedForGood(BlockId id) const { return state_[id] == BlockState::Failed && retry_from_update_[id] == 0; }
    const std::vector<BlockId>& idealSet() const { return ideal_; }
    /// Every block of the ideal set is resident (or failed).
    bool idealComplete() const { return stats_.ideal_missing == 0; }
    const BudgetStats& stats() const { return stats_; }

private:
    const TilesetIndex& index_;
    BudgetParams params_;
    std::vector<BlockState> state_;
    std::vector<uint8_t> in_ideal_;
    // Transient failures: the update from which the block may be tried again
    // (0: never), and its consecutive failures.
    std::vector<uint64_t> retry_from_update_;
    std::vector<uint16_t> failures_;
    uint64_t updates_ = 0;
    std::vector<BlockId> ideal_;
    BudgetStats stats_;
};

}  // namespace cityatlas::render
