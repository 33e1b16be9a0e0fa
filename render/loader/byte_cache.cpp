// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/loader/byte_cache.h"

namespace cityatlas::render {

bool ByteCache::get(BlockId id, std::vector<uint8_t>* out) {
    const auto it = entries_.find(id);
    if (it == entries_.end()) return false;
    *out = it->second.bytes;
    ++hits_;
    return true;
}

void ByteCache::evictFor(uint64_t incoming) {
    while (!order_.empty() && bytes_ + incoming > budget_) {
        const BlockId victim = static_cast<BlockId>(-order_.begin()->second);
        order_.erase(order_.begin());
        const auto it = entries_.find(victim);
        bytes_ -= it->second.bytes.size();
        entries_.erase(it);
    }
}

void ByteCache::put(BlockId id, std::vector<uint8_t> bytes) {
    if (const auto it = entries_.find(id); it != entries_.end()) {  // a newer copy replaces the old one
        order_.erase({it->second.stamp, -static_cast<int64_t>(id)});
        bytes_ -= it->second.bytes.size();
        entries_.erase(it);
    }
    if (bytes.size() > budget_) return;
    evictFor(bytes.size());
    bytes_ += bytes.size();
    order_.insert({frame_, -static_cast<int64_t>(id)});
    entries_.emplace(id, Entry{std::move(bytes), frame_});
}

void ByteCache::touch(const std::vector<BlockId>& ideal, uint64_t frame) {
    frame_ = std::max(frame_, frame);
    for (const BlockId id : ideal) {
        const auto it = entries_.find(id);
        if (it == entries_.end() || it->second.stamp == frame_) continue;
        order_.erase({it->second.stamp, -static_cast<int64_t>(id)});
        it->second.stamp = frame_;
        order_.insert({frame_, -static_cast<int64_t>(id)});
    }
}

}  // namespace cityatlas::render
