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
    // By sorting (path hash, entry) pairs, 16 bytes a texture while it runs:
    // a hash map of the same took ~44 (its buckets and nodes), the most a
    // merge held per texture at its end.
    struct Keyed {
        uint64_t hash;
        uint32_t t;
        bool operator<(const Keyed& o) const { return hash != o.hash ? hash < o.hash : t < o.t; }
    };
    std::vector<uint32_t> first(size());
    std::vector<Keyed> keyed(size());
    for (size_t t = 0; t < size(); ++t) keyed[t] = {std::hash<std::string>{}(path(t)), static_cast<uint32_t>(t)};
    std::sort(keyed.begin(), keyed.end());
    std::vector<std::pair<std::string, uint32_t>> seen;  // the distinct paths of one hash (compared whole: exact), first entries
    for (size_t i = 0; i < keyed.size();) {
        size_t end = i + 1;
        while (end < keyed.size() && keyed[end].hash == keyed[i].hash) ++end;
        first[keyed[i].t] = keyed[i].t;
        if (end > i + 1) {
            // Entries in ascending order: each is the first of its path or repeats an earlier one.
            seen.clear();
            for (size_t k = i; k < end; ++k) {
                std::string p = path(keyed[k].t);
                const auto it = std::find_if(seen.begin(), seen.end(), [&](const auto& s) { return s.first == p; });
                if (it != seen.end()) {
                    first[keyed[k].t] = it->second;
                } else {
                    first[keyed[k].t] = keyed[k].t;
                    seen.emplace_back(std::move(p), keyed[k].t);
                }
            }
        }
        i = end;
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
