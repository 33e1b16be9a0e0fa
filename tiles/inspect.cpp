// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/inspect.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <mutex>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <valijson/adapters/nlohmann_json_adapter.hpp>
#include <valijson/schema.hpp>
#include <valijson/schema_parser.hpp>
#include <valijson/validation_results.hpp>
#include <valijson/validator.hpp>

#include "tiles/glb_writer.h"
#include "tiles/texture_codec.h"
#include "tiles/tileset.h"

namespace cityatlas::tiles {

const nlohmann::json& tilesetSchema() {
    static const nlohmann::json schema = nlohmann::json::parse(
#include "tiles/tileset_schema.inc"
    );
    return schema;
}

namespace {
namespace fs = std::filesystem;
using nlohmann::json;

// The reason a DDS header is unusable, or empty.
std::string parseDds(const uint8_t* data, size_t size, DdsInfo* out) {
    const Status st = parseDdsHeader(data, size, out);
    return st.ok() ? std::string() : st.error;
}

std::vector<uint8_t> readBytes(const fs::path& p, size_t limit = SIZE_MAX) {
    std::ifstream f(p, std::ios::binary);
    std::vector<uint8_t> b;
    if (!f) return b;
    f.seekg(0, std::ios::end);
    const auto size = static_cast<size_t>(std::max<std::streamoff>(0, f.tellg()));
    f.seekg(0);
    b.resize(std::min(size, limit));
    f.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(b.size()));
    return b;
}

class Inspector {
public:
    Inspector(fs::path folder, InspectResult* r) : folder_(std::move(folder)), r_(r) {
        std::error_code ec;
        root_ = fs::weakly_canonical(folder_, ec);
    }

    void defect(const std::string& where, const std::string& what) {
        std::lock_guard lock(mutex_);
        r_->defects.push_back(fmt::format("{}: {}", where, what));
    }

    // The file behind a uri: exists, inside the folder, of `bytes` bytes (when >= 0).
    bool checkFile(const std::string& uri, int64_t bytes) {
        {
            std::lock_guard lock(mutex_);
            ++r_->files_checked;
        }
        if (uri.empty() || uri.front() == '/' || uri.find("..") != std::string::npos) {
            defect(uri, "not a relative uri inside the folder");
            return false;
        }
        std::error_code ec;
        const fs::path p = folder_ / uri;
        if (!fs::is_regular_file(p, ec)) {
            defect(uri, "missing");
            return false;
        }
        const fs::path c = fs::weakly_canonical(p, ec);
        const auto rel = c.lexically_relative(root_);
        if (ec || rel.empty() || *rel.begin() == "..") {
            defect(uri, "resolves outside the folder");
            return false;
        }
        const auto size = fs::file_size(p, ec);
        if (bytes >= 0 && size != static_cast<uint64_t>(bytes)) {
            defect(uri, fmt::format("{} bytes, tileset.json says {}", size, bytes));
            return false;
        }
        return true;
    }

    fs::path path(const std::string& uri) const { return folder_ / uri; }

private:
    fs::path folder_, root_;
    InspectResult* r_;
    std::mutex mutex_;
};

std::string validateSchema(const json& doc, std::vector<std::string>* errors) {
    try {
        valijson::Schema schema;
        valijson::SchemaParser parser(valijson::SchemaParser::kDraft7);
        valijson::adapters::NlohmannJsonAdapter schema_adapter(tilesetSchema());
        parser.populateSchema(schema_adapter, schema);
        valijson::Validator validator;
        valijson::ValidationResults results;
        valijson::adapters::NlohmannJsonAdapter doc_adapter(doc);
        if (validator.validate(schema, doc_adapter, &results)) return {};
        valijson::ValidationResults::Error e;
        while (results.popError(e)) {
            std::string where;
            for (const std::string& c : e.context) where += c == "<root>" ? "" : c;
            errors->push_back(fmt::format("tileset.json: {}: {}", where.empty() ? "/" : where, e.description));
            if (errors->size() >= 20) break;
        }
        return "schema";
    } catch (const std::exception& ex) {
        return std::string("schema validation failed: ") + ex.what();
    }
}

struct NodeRef {
    const json* tile;
    const json* parent;
};

}  // namespace

InspectResult inspectTileFolder(const fs::path& folder, int threads) {
    InspectResult r;
    Inspector in(folder, &r);
    json ts;
    {
        std::ifstream f(folder / "tileset.json");
        if (!f) {
            in.defect((folder / "tileset.json").string(), "missing: not a cityatlas tile folder");
            return r;
        }
        try {
            ts = json::parse(f);
        } catch (const std::exception& e) {
            in.defect("tileset.json", fmt::format("not valid JSON: {}", e.what()));
            return r;
        }
    }
    std::vector<std::string> schema_errors;
    const std::string schema_status = validateSchema(ts, &schema_errors);
    for (const std::string& e : schema_errors) r.defects.push_back(e);
    if (!schema_status.empty() && schema_status != "schema") r.defects.push_back("tileset.json: " + schema_status);
    if (!r.defects.empty()) return r;  // the structure below relies on the schema

    const json& ca = ts["extras"]["cityatlas"];
    const double focal = ca["build"]["focal_px"];
    const auto n_textures = ca["textures"].size();
    const auto n_materials = ca["materials"].size();
    const auto n_features = ca["features"]["count"].get<uint64_t>();

    // The tree, flattened in preorder, with structural checks.
    std::vector<NodeRef> nodes;
    std::set<int64_t> ids;
    std::function<void(const json&, const json*)> walk = [&](const json& tile, const json* parent) {
        const json& n = tile["extras"]["cityatlas"];
        const std::string where = fmt::format("tileset.json: node {}", n["id"].get<int64_t>());
        if (!ids.insert(n["id"].get<int64_t>()).second) in.defect(where, "id used twice");
        if (std::abs(tile["geometricError"].get<double>() * focal - n["min_distance_m"].get<double>()) >
            1e-9 * std::max(1.0, n["min_distance_m"].get<double>()))
            in.defect(where, "geometricError != min_distance_m / focal_px");
        for (const auto& [lname, L] : n["layers"].items())
            if (L["geometric_error_m"].get<double>() > 0 &&
                L["geometric_error_m"].get<double>() >= n["world_texel_m"].get<double>())
                in.defect(where, fmt::format("{} geometric error {} m is not below the world texel {} m", lname,
                                             L["geometric_error_m"].get<double>(), n["world_texel_m"].get<double>()));
        if (parent != nullptr) {
            const json& p = (*parent)["extras"]["cityatlas"];
            if (n["level"].get<int>() != p["level"].get<int>() + 1) in.defect(where, "level is not its parent's + 1");
            if (n["quadrant"].get<int>() < 0) in.defect(where, "a child without a quadrant");
            const json& cb = tile["boundingVolume"]["box"];
            const json& pb = (*parent)["boundingVolume"]["box"];
            for (int k = 0; k < 3; ++k) {
                const double c = cb[k], ch = std::abs(cb[3 + 4 * k].get<double>());
                const double pc = pb[k], ph = std::abs(pb[3 + 4 * k].get<double>());
                const double tol = 1e-6 * std::max({1.0, std::abs(pc), ph}) + 1e-6;
                if (c - ch < pc - ph - tol || c + ch > pc + ph + tol)
                    in.defect(where, "bounding box is not inside its parent's");
            }
        }
        nodes.push_back({&tile, parent});
        if (tile.contains("children")) {
            std::set<int> quadrants;
            for (const json& c : tile["children"]) {
                if (!quadrants.insert(c["extras"]["cityatlas"]["quadrant"].get<int>()).second)
                    in.defect(where, "two children in one quadrant");
                walk(c, &tile);
            }
        }
    };
    walk(ts["root"], nullptr);
    for (int64_t i = 0; i < static_cast<int64_t>(nodes.size()); ++i)
        if (!ids.count(i)) {
            in.defect("tileset.json", fmt::format("node ids are not 0..{}", nodes.size() - 1));
            break;
        }

    // Blocks of every node, in parallel (Draco decoding is the slow part).
    std::vector<uint64_t> geometry_bytes(nodes.size()), atlas_bytes(nodes.size()), triangles(nodes.size());
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
        tbb::parallel_for(size_t{0}, nodes.size(), [&](size_t i) {
            const json& tile = *nodes[i].tile;
            const json& n = tile["extras"]["cityatlas"];
            const bool leaf = !tile.contains("children");
            const Vec3d centre{n["centre"][0].get<double>(), n["centre"][1].get<double>(), n["centre"][2].get<double>()};
            for (const auto& [lname, L] : n["layers"].items()) {
                const std::string uri = L["geometry"]["uri"];
                if (in.checkFile(uri, L["geometry"]["bytes"].get<int64_t>())) {
                    geometry_bytes[i] += L["geometry"]["bytes"].get<uint64_t>();
                    TileMesh m;
                    const Status st = decodeTileGlb(readBytes(in.path(uri)), centre, &m);
                    if (!st.ok()) {
                        in.defect(uri, st.error);
                    } else {
                        triangles[i] += m.indices.size() / 3;
                        if (m.indices.size() / 3 != L["triangles"].get<size_t>())
                            in.defect(uri, fmt::format("{} triangles, tileset.json says {}", m.indices.size() / 3,
                                                       L["triangles"].get<size_t>()));
                        if (m.feature_id.empty()) in.defect(uri, "no feature ids");
                        for (uint32_t f : m.feature_id)
                            if (f >= n_features) {
                                in.defect(uri, fmt::format("feature id {} >= {} features", f, n_features));
                                break;
                            }
                        for (int32_t t : m.texture_id)
                            if (t >= static_cast<int64_t>(n_textures)) {
                                in.defect(uri, fmt::format("texture id {} >= {} textures", t, n_textures));
                                break;
                            }
                        for (int32_t t : m.material_id)
                            if (t >= static_cast<int64_t>(n_materials)) {
                                in.defect(uri, fmt::format("material id {} >= {} materials", t, n_materials));
                                break;
                            }
                        const bool textured = std::any_of(m.texture_id.begin(), m.texture_id.end(), [](int32_t t) { return t >= 0; });
                        if (leaf && textured && m.uv_original.empty()) in.defect(uri, "textured leaf without original uvs");
                        if (!L["atlas"].is_null() && m.uv_atlas.empty()) in.defect(uri, "an atlas but no atlas uvs");
                    }
                }
                if (L["atlas"].is_null()) continue;
                const json& a = L["atlas"];
                const std::string auri = a["uri"];
                if (!in.checkFile(auri, a["bytes"].get<int64_t>())) continue;
                atlas_bytes[i] += a["bytes"].get<uint64_t>();
                const std::vector<uint8_t> head = readBytes(in.path(auri), 128);
                DdsInfo d;
                if (std::string why = parseDds(head.data(), head.size(), &d); !why.empty()) {
                    in.defect(auri, why);
                    continue;
                }
                const int want_channels = lname == "alpha" ? 4 : 3;
                if (d.channels != want_channels || (a["format"] == "BC3") != (d.channels == 4))
                    in.defect(auri, fmt::format("DDS is {}, the {} layer needs {}", d.channels == 4 ? "BC3" : "BC1", lname,
                                                want_channels == 4 ? "BC3" : "BC1"));
                if (d.width != a["size_px"].get<int>() || d.height != a["size_px"].get<int>() || d.mips != a["mips"].get<int>())
                    in.defect(auri, fmt::format("DDS is {}x{} with {} mips, tileset.json says {}x{} with {}", d.width,
                                                d.height, d.mips, a["size_px"].get<int>(), a["size_px"].get<int>(),
                                                a["mips"].get<int>()));
                if (d.expected_bytes != a["bytes"].get<uint64_t>())
                    in.defect(auri, fmt::format("{} bytes, a DDS with this header has {}", a["bytes"].get<uint64_t>(),
                                                d.expected_bytes));
            }
            for (const json& b : n["texture_blocks"])
                if (b.get<size_t>() >= ca["texture_blocks"].size())
                    in.defect(fmt::format("tileset.json: node {}", n["id"].get<int64_t>()), "names a texture block that does not exist");
        });
    });

    // Texture blocks and the textures inside them.
    std::vector<bool> block_ok;
    for (const json& b : ca["texture_blocks"]) {
        block_ok.push_back(in.checkFile(b["uri"], b["bytes"].get<int64_t>()));
        if (block_ok.back()) r.bytes_textures += b["bytes"].get<uint64_t>();
    }
    r.texture_blocks = block_ok.size();
    for (size_t t = 0; t < ca["textures"].size(); ++t) {
        const json& e = ca["textures"][t];
        ++r.textures;
        const int block = e["block"];
        if (block < 0) continue;
        const std::string where = fmt::format("tileset.json: texture {}", t);
        if (static_cast<size_t>(block) >= block_ok.size()) {
            in.defect(where, "names a texture block that does not exist");
            continue;
        }
        const json& b = ca["texture_blocks"][static_cast<size_t>(block)];
        if (!block_ok[static_cast<size_t>(block)]) continue;
        const auto offset = e["offset"].get<uint64_t>(), bytes = e["bytes"].get<uint64_t>();
        const std::string buri = b["uri"];
        if (offset + bytes > b["bytes"].get<uint64_t>() || offset + bytes < offset) {
            in.defect(buri, fmt::format("texture {} (offset {}, {} bytes) lies outside the block", t, offset, bytes));
            continue;
        }
        std::ifstream f(in.path(buri), std::ios::binary);
        std::vector<uint8_t> head(128);
        f.seekg(static_cast<std::streamoff>(offset));
        f.read(reinterpret_cast<char*>(head.data()), 128);
        head.resize(static_cast<size_t>(f.gcount()));
        DdsInfo d;
        if (std::string why = parseDds(head.data(), head.size(), &d); !why.empty()) {
            in.defect(buri, fmt::format("texture {} at offset {}: {}", t, offset, why));
            continue;
        }
        if (d.width != e["width"].get<int>() || d.height != e["height"].get<int>() || d.mips != e["mips"].get<int>() ||
            (d.channels == 4) != (e["format"] == "BC3") || d.expected_bytes != bytes)
            in.defect(buri, fmt::format("texture {} at offset {}: the DDS ({}x{}, {} mips, {} bytes) does not match its "
                                        "entry ({}x{}, {} mips, {} bytes)",
                                        t, offset, d.width, d.height, d.mips, d.expected_bytes, e["width"].get<int>(),
                                        e["height"].get<int>(), e["mips"].get<int>(), bytes));
    }

    // Feature tables.
    const auto bs = ca["features"]["block_size"].get<uint64_t>();
    const json& tables = ca["features"]["tables"];
    if (tables.size() != (n_features + bs - 1) / bs)
        in.defect("tileset.json", fmt::format("{} feature tables for {} features in blocks of {}", tables.size(), n_features, bs));
    for (size_t k = 0; k < tables.size(); ++k) {
        const std::string uri = tables[k]["uri"];
        if (!in.checkFile(uri, tables[k]["bytes"].get<int64_t>())) continue;
        r.bytes_features += tables[k]["bytes"].get<uint64_t>();
        try {
            std::ifstream f(in.path(uri));
            const json t = json::parse(f);
            const uint64_t first = t.at("first").get<uint64_t>();
            const json& list = t.at("features");
            const uint64_t want = std::min<uint64_t>(bs, n_features - std::min(n_features, k * bs));
            if (first != k * bs || list.size() != want) {
                in.defect(uri, fmt::format("holds ids {}..+{}, expected {}..+{}", first, list.size(), k * bs, want));
                continue;
            }
            for (size_t i = 0; i < list.size(); ++i)
                if (list[i].at("id").get<uint64_t>() != first + i) {
                    in.defect(uri, fmt::format("entry {} has id {}, expected {}", i, list[i].at("id").get<uint64_t>(), first + i));
                    break;
                }
            r.features += list.size();
        } catch (const std::exception& e) {
            in.defect(uri, fmt::format("not a feature table: {}", e.what()));
        }
    }

    // Per level summary and totals.
    for (size_t i = 0; i < nodes.size(); ++i) {
        const json& tile = *nodes[i].tile;
        const json& n = tile["extras"]["cityatlas"];
        const auto level = n["level"].get<size_t>();
        if (r.levels.size() <= level) r.levels.resize(level + 1);
        InspectLevel& L = r.levels[level];
        const double texel = n["world_texel_m"];
        L.world_texel_min_m = L.nodes ? std::min(L.world_texel_min_m, texel) : texel;
        L.world_texel_max_m = std::max(L.world_texel_max_m, texel);
        L.min_distance_m = std::max(L.min_distance_m, n["min_distance_m"].get<double>());
        ++L.nodes;
        const bool leaf = !tile.contains("children");
        L.leaves += leaf ? 1 : 0;
        L.triangles += triangles[i];
        L.bytes_geometry += geometry_bytes[i];
        L.bytes_atlases += atlas_bytes[i];
        ++r.nodes;
        r.leaves += leaf ? 1 : 0;
        r.bytes_geometry += geometry_bytes[i];
        r.bytes_atlases += atlas_bytes[i];
    }
    const json& totals = ca["totals"];
    auto total = [&](const char* what, uint64_t found, uint64_t claimed) {
        if (found != claimed)
            in.defect("tileset.json", fmt::format("totals: {} is {}, the folder has {}", what, claimed, found));
    };
    total("nodes", r.nodes, totals["nodes"]);
    total("leaves", r.leaves, totals["leaves"]);
    total("depth", r.levels.empty() ? 0 : r.levels.size() - 1, totals["depth"]);
    total("bytes.geometry", r.bytes_geometry, totals["bytes"]["geometry"]);
    total("bytes.atlases", r.bytes_atlases, totals["bytes"]["atlases"]);
    total("bytes.textures", r.bytes_textures, totals["bytes"]["textures"]);
    total("bytes.features", r.bytes_features, totals["bytes"]["features"]);
    std::sort(r.defects.begin(), r.defects.end());
    return r;
}

}  // namespace cityatlas::tiles
