// SPDX-License-Identifier: GPL-3.0-or-later
#include "cli/build_hash.h"

#include <algorithm>
#include <fstream>
#include <memory>

#include <fmt/format.h>
#include <xxhash.h>

namespace cityatlas::cli {
namespace fs = std::filesystem;

Status digestFile(const fs::path& path, FileDigest* out) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot open for hashing", path.string()));
    std::unique_ptr<XXH3_state_t, decltype(&XXH3_freeState)> state(XXH3_createState(), &XXH3_freeState);
    XXH3_64bits_reset(state.get());
    std::vector<char> buffer(1 << 20);
    uint64_t bytes = 0;
    while (f) {
        f.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
        const auto n = static_cast<size_t>(f.gcount());
        XXH3_64bits_update(state.get(), buffer.data(), n);
        bytes += n;
    }
    if (f.bad()) return Status::Io(fmt::format("{}: read error while hashing", path.string()));
    out->path = path.string();
    out->bytes = bytes;
    out->xxh3 = fmt::format("{:016x}", XXH3_64bits_digest(state.get()));
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

std::string hashStrings(const std::vector<std::string>& parts) {
    std::string all;
    for (const std::string& s : parts) all += fmt::format("{}:{};", s.size(), s);
    return fmt::format("{:016x}", XXH3_64bits(all.data(), all.size()));
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
