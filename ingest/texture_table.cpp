// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/texture_table.h"

#include <algorithm>

#include "core/external_sort.h"

namespace cityatlas {

namespace {
constexpr size_t kChunk = size_t{1} << 20;

// A path's folder (up to and including its last separator) and file name.
std::pair<std::string_view, std::string_view> splitPath(std::string_view path) {
    const size_t slash = path.find_last_of('/');
    if (slash == std::string_view::npos) return {std::string_view(), path};
    return {path.substr(0, slash + 1), path.substr(slash + 1)};
}
}  // namespace

void TextureTable::clear() { *this = TextureTable(); }

uint32_t TextureTable::folderId(std::string_view folder) {
    const auto [it, inserted] = folder_ids_.try_emplace(std::string(folder), static_cast<uint32_t>(folders_.size()));
    if (inserted) folders_.emplace_back(folder);
    return it->second;
}

TextureTable::Name TextureTable::store(std::string_view path) {
    const auto [folder, file] = splitPath(path);
    Name n;
    n.folder = folderId(folder);
    n.length = static_cast<uint32_t>(file.size());
    if (chunks_.empty() || chunks_.back().size() + file.size() > chunks_.back().capacity()) {
        chunks_.emplace_back();
        chunks_.back().reserve(std::max(kChunk, file.size()));
    }
    n.chunk = static_cast<uint32_t>(chunks_.size() - 1);
    n.offset = static_cast<uint32_t>(chunks_.back().size());
    chunks_.back().append(file);
    return n;
}

void TextureTable::push_back(const TextureRef& t) {
    info_.push_back(t);
    names_at_.push_back(store(t.path));
}

void TextureTable::set(size_t i, const TextureRef& t) {
    info_[i] = t;
    names_at_[i] = store(t.path);
}

std::string TextureTable::path(size_t i) const {
    const Name& n = names_at_[i];
    const std::string& folder = folders_[n.folder];
    std::string p;
    p.reserve(folder.size() + n.length);
    p.append(folder).append(std::string_view(chunks_[n.chunk]).substr(n.offset, n.length));
    return p;
}

TextureRef TextureTable::ref(size_t i) const {
    const TextureInfo& t = info_[i];
    return {path(i), t.width_px, t.height_px, t.channels, t.wrap};
}

std::vector<uint32_t> TextureTable::firstOfPath(const std::filesystem::path& scratch_dir, size_t memory_bytes) const {
    // (path hash, entry) pairs sorted on disk beyond 32 MB: a hash map of the
    // paths took ~44 bytes a texture (its buckets and nodes), and the sorted
    // pairs in memory 16: the most a merge held per texture at its end.
    struct Keyed {
        uint64_t hash;
        uint32_t t;
        bool operator<(const Keyed& o) const { return hash != o.hash ? hash < o.hash : t < o.t; }
    };
    std::vector<uint32_t> first(size());
    // Entries of one hash come in ascending order: each is the first of its
    // path or repeats an earlier one (paths compared whole: exact).
    uint64_t group_hash = 0;
    bool in_group = false;
    std::vector<std::pair<std::string, uint32_t>> seen;  // the group's distinct paths so far, lazily
    uint32_t group_first = 0;
    const auto visit = [&](const Keyed& k) {
        if (!in_group || k.hash != group_hash) {
            in_group = true, group_hash = k.hash, group_first = k.t;
            seen.clear();
            first[k.t] = k.t;
            return;
        }
        if (seen.empty()) seen.emplace_back(path(group_first), group_first);  // only a hash that repeats needs paths
        std::string p = path(k.t);
        const auto it = std::find_if(seen.begin(), seen.end(), [&](const auto& s) { return s.first == p; });
        first[k.t] = it != seen.end() ? it->second : k.t;
        if (it == seen.end()) seen.emplace_back(std::move(p), k.t);
    };
    const auto keyOf = [&](size_t t) { return Keyed{std::hash<std::string>{}(path(t)), static_cast<uint32_t>(t)}; };
    ExternalSorter<Keyed> sorter(scratch_dir, memory_bytes);
    Status sorted;
    for (size_t t = 0; t < size() && sorted.ok(); ++t) sorted = sorter.push(keyOf(t));
    if (sorted.ok()) sorted = sorter.forEachSorted(visit);
    if (sorted.ok()) return first;
    // No room for the runs (a full disk): the same in memory.
    std::vector<Keyed> keyed(size());
    for (size_t t = 0; t < size(); ++t) keyed[t] = keyOf(t);
    std::sort(keyed.begin(), keyed.end());
    in_group = false;
    for (const Keyed& k : keyed) visit(k);
    return first;
}

size_t TextureTable::bytes() const {
    size_t b = info_.size() * sizeof(TextureInfo) + names_at_.size() * sizeof(Name);
    for (const std::string& c : chunks_) b += c.capacity();
    for (const std::string& f : folders_) b += f.capacity() + 64;  // the string, its map entry and key
    return b;
}

}  // namespace cityatlas
