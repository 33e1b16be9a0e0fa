// SPDX-License-Identifier: GPL-3.0-or-later
#include "cli/build_hash.h"

#include <algorithm>
#include <fstream>
#include <memory>
#include <string_view>
#include <unordered_map>
#include <unordered_set>

#include <fmt/format.h>
#include <xxhash.h>

namespace cityatlas::cli {
namespace fs = std::filesystem;

namespace {
// XXH3-64 and size of a file's contents, streamed through one buffer per
// thread: a fresh 1 MB buffer per file zeroed a terabyte of memory for a
// million 3 kB textures.
Status hashFile(const fs::path& path, uint64_t* xxh3, uint64_t* bytes) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot open for hashing", path.string()));
    std::unique_ptr<XXH3_state_t, decltype(&XXH3_freeState)> state(XXH3_createState(), &XXH3_freeState);
    XXH3_64bits_reset(state.get());
    thread_local std::vector<char> buffer(1 << 20);
    *bytes = 0;
    while (f) {
        f.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
        const auto n = static_cast<size_t>(f.gcount());
        XXH3_64bits_update(state.get(), buffer.data(), n);
        *bytes += n;
    }
    if (f.bad()) return Status::Io(fmt::format("{}: read error while hashing", path.string()));
    *xxh3 = XXH3_64bits_digest(state.get());
    return Status::Ok();
}
}  // namespace

Status digestFile(const fs::path& path, FileDigest* out) {
    uint64_t xxh3 = 0, bytes = 0;
    if (Status s = hashFile(path, &xxh3, &bytes); !s.ok()) return s;
    out->path = path.string();
    out->bytes = bytes;
    out->xxh3 = hexDigest(xxh3);
    return Status::Ok();
}

std::vector<fs::path> withSidecars(const std::vector<fs::path>& inputs) {
    std::vector<fs::path> out;
    for (const fs::path& p : inputs) {
        out.push_back(p);
        std::string ext = p.extension().string();
        std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
        if (ext != ".shp") continue;
        for (const char* side : {".shx", ".dbf", ".prj", ".cpg", ".SHX", ".DBF", ".PRJ", ".CPG"}) {
            fs::path s = p;
            s.replace_extension(side);
            std::error_code ec;
            if (fs::is_regular_file(s, ec)) out.push_back(s);
        }
    }
    std::vector<fs::path> unique;
    for (const fs::path& p : out)
        if (std::find(unique.begin(), unique.end(), p) == unique.end()) unique.push_back(p);
    return unique;
}

Status digestTextures(const TextureTable& textures, RecordFile<TextureDigest>* out,
                      const std::filesystem::path& scratch_dir) {
    Status failed;
    textures.forEachFirstOfPath([&](size_t t, size_t first) {
        if (!failed.ok()) return;
        TextureDigest d;
        if (first != t) {
            d = out->read(first);
        } else {
            uint64_t bytes = 0;
            d.readable = hashFile(textures.path(t), &d.xxh3, &bytes).ok();  // unreadable ones are ingest warnings
            d.bytes = bytes;
        }
        failed = out->append(d);
    }, scratch_dir);
    if (!failed.ok()) return failed;
    return out->status();
}

std::string hexDigest(uint64_t xxh3) { return fmt::format("{:016x}", xxh3); }

void forEachFingerprintTexture(const TextureTable& textures, const DigestAt& digest,
                               const std::function<void(size_t)>& fn, const std::filesystem::path& scratch_dir) {
    textures.forEachFirstOfPath(
        [&](size_t t, size_t first) {
            if (first == t && digest(t).readable) fn(t);
        },
        scratch_dir);
}

namespace {
// hashStrings, one part at a time.
class StringsHash {
public:
    StringsHash() : state_(XXH3_createState(), &XXH3_freeState) { XXH3_64bits_reset(state_.get()); }
    void add(std::string_view s) {
        const std::string prefix = fmt::format("{}:", s.size());
        XXH3_64bits_update(state_.get(), prefix.data(), prefix.size());
        XXH3_64bits_update(state_.get(), s.data(), s.size());
        XXH3_64bits_update(state_.get(), ";", 1);
    }
    std::string digest() const { return hexDigest(XXH3_64bits_digest(state_.get())); }

private:
    std::unique_ptr<XXH3_state_t, decltype(&XXH3_freeState)> state_;
};
}  // namespace

std::string buildHash(const std::string& inputs_key, const TextureTable& textures, const DigestAt& digest,
                      const std::function<std::string(std::string)>& path_as) {
    StringsHash h;
    h.add(inputs_key);
    forEachFingerprintTexture(textures, digest, [&](size_t t) {
        h.add(fmt::format("{}={}", path_as ? path_as(textures.path(t)) : textures.path(t), hexDigest(digest(t).xxh3)));
    });
    return h.digest();
}

std::string hashStrings(const std::vector<std::string>& parts) {
    StringsHash h;
    for (const std::string& s : parts) h.add(s);
    return h.digest();
}

nlohmann::json toJson(const std::vector<FileDigest>& digests) {
    nlohmann::json a = nlohmann::json::array();
    for (const FileDigest& d : digests) a.push_back({{"path", d.path}, {"bytes", d.bytes}, {"xxh3", d.xxh3}});
    return a;
}

std::vector<FileDigest> digestsFromJson(const nlohmann::json& j) {
    std::vector<FileDigest> out;
    if (!j.is_array()) return out;
    for (const auto& e : j) {
        if (!e.is_object() || !e.contains("path") || !e["path"].is_string() || !e.contains("bytes") ||
            !e["bytes"].is_number_unsigned() || !e.contains("xxh3") || !e["xxh3"].is_string())
            return {};
        out.push_back({e["path"].get<std::string>(), e["bytes"].get<uint64_t>(), e["xxh3"].get<std::string>()});
    }
    return out;
}

}  // namespace cityatlas::cli
