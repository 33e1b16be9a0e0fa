// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/texture_table.h"

#include <algorithm>

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

std::vector<uint32_t> TextureTable::firstOfPath() const {
    std::vector<uint32_t> first(size());
    std::unordered_multimap<size_t, uint32_t> by_hash;  // path hash -> first entries (compared whole: exact)
    by_hash.reserve(size());
    for (size_t t = 0; t < size(); ++t) {
        const std::string p = path(t);
        const size_t h = std::hash<std::string>{}(p);
        first[t] = static_cast<uint32_t>(t);
        const auto [from, to] = by_hash.equal_range(h);
        for (auto it = from; it != to && first[t] == t; ++it)
            if (path(it->second) == p) first[t] = it->second;
        if (first[t] == t) by_hash.emplace(h, static_cast<uint32_t>(t));
    }
    return first;
}

size_t TextureTable::bytes() const {
    size_t b = info_.size() * sizeof(TextureInfo) + names_at_.size() * sizeof(Name);
    for (const std::string& c : chunks_) b += c.capacity();
    for (const std::string& f : folders_) b += f.capacity() + 64;  // the string, its map entry and key
    return b;
}

}  // namespace cityatlas
