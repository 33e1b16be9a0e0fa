// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/texture_table.h"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

#include "core/external_sort.h"

namespace cityatlas {

namespace {
constexpr size_t kChunk = size_t{1} << 20;  // paths held in memory before they go to the file
}  // namespace

size_t TextureTable::defaultMemoryBytes() {
    static const size_t bytes = [] {
        const char* mb = std::getenv("CITYATLAS_TABLE_MEMORY_MB");
        char* end = nullptr;
        const unsigned long long v = mb ? std::strtoull(mb, &end, 10) : 0;
        return mb && end != mb && *end == '\0' ? static_cast<size_t>(v) << 20 : size_t{64} << 20;
    }();
    return bytes;
}

TextureTable::TextureTable(std::filesystem::path scratch_dir, size_t memory_bytes)
    : scratch_dir_(std::move(scratch_dir)),
      entries_(scratch_dir_, "texture table", memory_bytes),
      file_(scratch_dir_, "cityatlas-texture-paths") {}

TextureTable::TextureTable(const TextureTable& other) : TextureTable(other.scratch_dir_, other.entries_.memoryBytes()) {
    for (size_t i = 0; i < other.size(); ++i) push_back(other.ref(i));
}

TextureTable& TextureTable::operator=(const TextureTable& other) {
    if (this != &other) *this = TextureTable(other);
    return *this;
}

void TextureTable::setScratchDir(const std::filesystem::path& scratch_dir) {
    if (tail_at_ > 0) return;  // paths already sealed: they stay where they went
    scratch_dir_ = scratch_dir;
    file_ = ScratchFile(scratch_dir_, "cityatlas-texture-paths");
    entries_.setScratchDir(scratch_dir_);
}

void TextureTable::clear() { *this = TextureTable(scratch_dir_, entries_.memoryBytes()); }

void TextureTable::seal() {
    if (tail_.empty()) return;
    const uint64_t sealed = tail_.size();
    // Once the file has failed (a full disk), the rest stays in memory: a
    // table that works as before rather than a build that stops.
    if (kept_.empty() && file_.write(on_disk_, tail_.data(), tail_.size(), "texture paths").ok()) {
        on_disk_ += sealed;
        tail_.clear();  // its buffer reused
    } else {
        kept_at_.push_back(tail_at_);
        kept_.push_back(std::move(tail_));
        tail_ = std::string();
    }
    tail_at_ += sealed;
}

uint64_t TextureTable::append(std::string_view path) {
    const size_t length = std::min<size_t>(path.size(), (size_t{1} << kLengthBits) - 1);
    if (!tail_.empty() && tail_.size() + length > kChunk) seal();  // a path never spans two chunks
    // Doubling up to a chunk (a small table stays small), never past it: a
    // string's own growth would double a chunk's memory.
    if (tail_.size() + length > tail_.capacity())
        tail_.reserve(std::max(tail_.size() + length, std::min(kChunk, std::max<size_t>(4096, 2 * tail_.capacity()))));
    const uint64_t offset = tail_at_ + tail_.size();
    tail_.append(path.substr(0, length));
    return offset << kLengthBits | length;
}

TextureTable::Entry TextureTable::entry(const TextureRef& t) {
    const uint64_t at = append(t.path);
    return {t, static_cast<uint32_t>(at), static_cast<uint32_t>(at >> 32)};
}

void TextureTable::push_back(const TextureRef& t) { entries_.push_back(entry(t)); }

void TextureTable::set(size_t i, const TextureRef& t) { entries_.set(i, entry(t)); }

std::string TextureTable::path(size_t i) const {
    const uint64_t at = entries_.get(i).at();
    const uint64_t offset = at >> kLengthBits;
    const size_t length = at & ((uint64_t{1} << kLengthBits) - 1);
    if (offset >= tail_at_) return tail_.substr(offset - tail_at_, length);
    if (offset >= on_disk_) {
        const size_t k = static_cast<size_t>(std::upper_bound(kept_at_.begin(), kept_at_.end(), offset) - kept_at_.begin()) - 1;
        return kept_[k].substr(offset - kept_at_[k], length);
    }
    std::string p(length, '\0');
    if (Status s = file_.read(offset, p.data(), length, "texture paths"); !s.ok()) throw std::runtime_error(s.error);
    return p;
}

TextureRef TextureTable::ref(size_t i) const {
    const TextureInfo t = entries_.get(i).info;
    return {path(i), t.width_px, t.height_px, t.channels, t.wrap};
}

void TextureTable::forEachFirstOfPath(const std::function<void(size_t t, size_t first)>& fn,
                                      const std::filesystem::path& scratch_dir, size_t memory_bytes) const {
    // (path hash, entry) pairs sorted on disk beyond 32 MB: a hash map of the
    // paths took ~44 bytes a texture (its buckets and nodes), and the sorted
    // pairs in memory 16. The answers come in hash order and go back to
    // texture order through a second sort, so nothing a texture is held.
    struct Keyed {
        uint64_t hash;
        uint32_t t;
        bool operator<(const Keyed& o) const { return hash != o.hash ? hash < o.hash : t < o.t; }
    };
    struct Answer {
        uint32_t t, first;
        bool operator<(const Answer& o) const { return t < o.t; }
    };
    // Entries of one hash come in ascending order: each is the first of its
    // path or repeats an earlier one (paths compared whole: exact).
    uint64_t group_hash = 0;
    bool in_group = false;
    std::vector<std::pair<std::string, uint32_t>> seen;  // the group's distinct paths so far, lazily
    uint32_t group_first = 0;
    const auto firstOf = [&](const Keyed& k) -> uint32_t {
        if (!in_group || k.hash != group_hash) {
            in_group = true, group_hash = k.hash, group_first = k.t;
            seen.clear();
            return k.t;
        }
        if (seen.empty()) seen.emplace_back(path(group_first), group_first);  // only a hash that repeats needs paths
        std::string p = path(k.t);
        const auto it = std::find_if(seen.begin(), seen.end(), [&](const auto& s) { return s.first == p; });
        if (it != seen.end()) return it->second;
        seen.emplace_back(std::move(p), k.t);
        return k.t;
    };
    const auto keyOf = [&](size_t t) { return Keyed{std::hash<std::string>{}(path(t)), static_cast<uint32_t>(t)}; };
    size_t done = 0;  // textures handed to fn: 0 .. done - 1
    {
        ExternalSorter<Keyed> by_path(scratch_dir, memory_bytes / 2);
        ExternalSorter<Answer> by_texture(scratch_dir, memory_bytes / 2);
        Status sorted;
        for (size_t t = 0; t < size() && sorted.ok(); ++t) sorted = by_path.push(keyOf(t));
        if (sorted.ok())
            sorted = by_path.forEachSorted([&](const Keyed& k) {
                if (sorted.ok()) sorted = by_texture.push({k.t, firstOf(k)});
            });
        if (sorted.ok()) {
            sorted = by_texture.forEachSorted([&](const Answer& a) {
                fn(a.t, a.first);
                ++done;
            });
            if (sorted.ok()) return;
        }
    }
    // No room for the runs (a full disk), or one that could not be read
    // back: the same in memory, from the first texture not yet handed over.
    std::vector<Keyed> keyed(size());
    for (size_t t = 0; t < size(); ++t) keyed[t] = keyOf(t);
    std::sort(keyed.begin(), keyed.end());
    std::vector<uint32_t> first(size());
    in_group = false;
    for (const Keyed& k : keyed) first[k.t] = firstOf(k);
    for (size_t t = done; t < first.size(); ++t) fn(t, first[t]);
}

size_t TextureTable::bytes() const {
    size_t b = entries_.bytes() + tail_.capacity();
    for (const std::string& k : kept_) b += k.capacity();
    return b;
}

}  // namespace cityatlas
