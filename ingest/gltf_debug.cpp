// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/gltf_debug.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "cityatlas_version.h"

namespace cityatlas {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

static_assert(std::endian::native == std::endian::little, "GLB is little-endian; add byte swapping");

constexpr uint32_t kDropped = std::numeric_limits<uint32_t>::max();

// glTF enums.
constexpr int kFloat = 5126;
constexpr int kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962;
constexpr int kLinear = 9729;
constexpr int kLinearMipmapLinear = 9987;
constexpr int kRepeat = 10497;
constexpr int kMirroredRepeat = 33648;
constexpr int kClampToEdge = 33071;

// GLB container.
constexpr uint32_t kGlbMagic = 0x46546C67;      // "glTF"
constexpr uint32_t kChunkJson = 0x4E4F534A;     // "JSON"
constexpr uint32_t kChunkBin = 0x004E4942;      // "BIN\0"

// Feature ids up to 2^24 are exact in float32. The validator accepts FLOAT for
// an application-specific attribute, and FLOAT is what every viewer can read; a
// scene with more features than that (never seen in practice) gets UNSIGNED_INT.
constexpr uint32_t kMaxExactFloatInt = 1u << 24;

int samplerWrap(WrapMode w) {
    switch (w) {
        case WrapMode::Wrap: return kRepeat;
        case WrapMode::Mirror: return kMirroredRepeat;
        case WrapMode::Clamp:
        case WrapMode::Border:
        case WrapMode::None: break;
    }
    return kClampToEdge;
}

// The corners of a triangle as float32, or false when one is not finite there
// (non-finite in double, or beyond float range).
bool floatCorners(const Triangle& t, std::array<float, 9>& out) {
    bool finite = true;
    for (int k = 0; k < 3; ++k) {
        const Vec3d& p = t.position_local[k];
        out[3 * k + 0] = static_cast<float>(p.x);
        out[3 * k + 1] = static_cast<float>(p.y);
        out[3 * k + 2] = static_cast<float>(p.z);
    }
    for (float v : out) finite = finite && std::isfinite(v);
    return finite;
}

float finiteOr0(double v) {
    const auto f = static_cast<float>(v);
    return std::isfinite(f) ? f : 0.0f;
}

float unitClamp(float v) { return std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f; }

// RFC 3986 relative reference from a '/'-separated path: everything but the
// unreserved characters and '/' is percent-encoded (bytes, so UTF-8 survives).
std::string percentEncodePath(const std::string& path) {
    static constexpr char kHex[] = "0123456789ABCDEF";
    std::string out;
    out.reserve(path.size());
    for (unsigned char c : path) {
        const bool unreserved = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                                c == '-' || c == '.' || c == '_' || c == '~' || c == '/';
        if (unreserved) {
            out += static_cast<char>(c);
        } else {
            out += '%';
            out += kHex[c >> 4];
            out += kHex[c & 15];
        }
    }
    return out;
}

fs::path canonicalOrAbsolute(const fs::path& p) {
    std::error_code ec;
    fs::path abs = fs::absolute(p, ec);
    if (ec) abs = p;
    fs::path canon = fs::weakly_canonical(abs, ec);
    return ec ? abs.lexically_normal() : canon;
}

// URI of a texture file as seen from the folder of the .glb.
std::string textureUri(const std::string& texture_path, const fs::path& glb_dir_canonical) {
    const fs::path tex = canonicalOrAbsolute(texture_path);
    const fs::path rel = tex.lexically_relative(glb_dir_canonical);
    if (!rel.empty() && rel != ".") return percentEncodePath(rel.generic_string());
    // No relative form (cannot happen for two absolute POSIX paths unless the
    // texture IS the folder): an absolute file URI.
    return "file://" + percentEncodePath(tex.generic_string());
}

// Buffered binary output to a FILE; remembers the first error (errno).
class Sink {
  public:
    explicit Sink(std::FILE* f) : f_(f), buf_(std::make_unique<char[]>(kCap)) {}
    void put(const void* data, size_t n) {
        if (err_ != 0) return;
        if (used_ + n > kCap) flush();
        if (n > kCap) {
            raw(data, n);
            return;
        }
        std::memcpy(buf_.get() + used_, data, n);
        used_ += n;
    }
    void u32(uint32_t v) { put(&v, 4); }
    void pad(size_t n, char c) {
        for (size_t i = 0; i < n; ++i) put(&c, 1);
    }
    void flush() {
        if (used_ > 0 && err_ == 0) raw(buf_.get(), used_);
        used_ = 0;
    }
    int error() const { return err_; }

  private:
    static constexpr size_t kCap = size_t{1} << 20;
    void raw(const void* data, size_t n) {
        if (err_ != 0) return;
        errno = 0;
        if (std::fwrite(data, 1, n, f_) != n) err_ = errno != 0 ? errno : EIO;
    }
    std::FILE* f_;
    std::unique_ptr<char[]> buf_;
    size_t used_ = 0;
    int err_ = 0;
};

struct Group {
    uint64_t triangles = 0;
    uint64_t first = 0;  ///< index of its first triangle in the sorted order
    std::array<float, 3> min{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                             std::numeric_limits<float>::max()};
    std::array<float, 3> max{std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest(),
                             std::numeric_limits<float>::lowest()};
    uint32_t feature_min = std::numeric_limits<uint32_t>::max();
    uint32_t feature_max = 0;
};

Json floats(const std::array<float, 3>& v) {
    return Json::array({static_cast<double>(v[0]), static_cast<double>(v[1]), static_cast<double>(v[2])});
}

}  // namespace

Status writeDebugGlb(const Scene& scene, const std::filesystem::path& glb_path) {
    const std::string where = glb_path.string();
    if (glb_path.empty() || !glb_path.has_filename())
        return Status::Fail(fmt::format("{}: not a file name for the debug glb", where));

    // --- Classify: group of every triangle (texture, then material, then grey). ---
    const size_t n_tex = scene.textures.size();
    const size_t n_mat = scene.materials.size();
    const size_t n_groups = n_tex + n_mat + 1;
    const size_t grey = n_tex + n_mat;
    std::vector<bool> texture_usable(n_tex);
    for (size_t i = 0; i < n_tex; ++i) texture_usable[i] = !scene.textures[i].path.empty();

    const size_t n_tri = scene.triangles.size();
    std::vector<uint32_t> tri_group(n_tri);
    std::vector<Group> groups(n_groups);
    uint64_t dropped = 0;
    std::array<float, 9> c{};
    for (size_t i = 0; i < n_tri; ++i) {
        const Triangle& t = scene.triangles[i];
        if (!floatCorners(t, c)) {
            tri_group[i] = kDropped;
            ++dropped;
            continue;
        }
        size_t g = grey;
        if (t.texture >= 0 && static_cast<size_t>(t.texture) < n_tex && texture_usable[t.texture])
            g = static_cast<size_t>(t.texture);
        else if (t.material >= 0 && static_cast<size_t>(t.material) < n_mat)
            g = n_tex + static_cast<size_t>(t.material);
        tri_group[i] = static_cast<uint32_t>(g);
        Group& gr = groups[g];
        ++gr.triangles;
        for (int k = 0; k < 3; ++k) {
            for (int a = 0; a < 3; ++a) {
                gr.min[a] = std::min(gr.min[a], c[3 * k + a]);
                gr.max[a] = std::max(gr.max[a], c[3 * k + a]);
            }
        }
        gr.feature_min = std::min(gr.feature_min, t.feature);
        gr.feature_max = std::max(gr.feature_max, t.feature);
    }
    if (n_groups >= kDropped) return Status::Fail(fmt::format("{}: too many textures and materials", where));

    // --- Sizes and layout (positions | uvs of textured groups | feature ids). ---
    uint64_t vertices = 0, textured_vertices = 0, written = 0;
    uint32_t feature_max = 0;
    for (size_t g = 0; g < n_groups; ++g) {
        groups[g].first = written;
        written += groups[g].triangles;
        vertices += 3 * groups[g].triangles;
        if (g < n_tex) textured_vertices += 3 * groups[g].triangles;
        if (groups[g].triangles > 0) feature_max = std::max(feature_max, groups[g].feature_max);
    }
    const bool feature_as_float = feature_max <= kMaxExactFloatInt;
    const uint64_t pos_bytes = vertices * 12, uv_bytes = textured_vertices * 8, feat_bytes = vertices * 4;
    const uint64_t bin_bytes = pos_bytes + uv_bytes + feat_bytes;  // multiple of 4
    // Leaves room for the JSON (bounded below, once it is known).
    if (bin_bytes > std::numeric_limits<uint32_t>::max() - (uint64_t{64} << 20))
        return Status::Fail(fmt::format("{}: {} triangles are too many for one GLB (4 GiB limit)", where, written));

    // --- JSON. ---
    Json j;
    j["asset"] = {
        {"version", "2.0"},
        {"generator", fmt::format("cityatlas {} (debug view of a Scene)", kCityAtlasVersion)},
        {"extras",
         {{"source_crs", scene.georef.source_crs},
          {"origin_source", Json::array({scene.georef.origin_source.x, scene.georef.origin_source.y,
                                         scene.georef.origin_source.z})},
          {"frame", "positions in local east/north/up metres relative to origin_source; the root node "
                    "rotates z-up to y-up"},
          {"triangles", written},
          {"dropped_triangles", dropped}}}};
    j["scene"] = 0;
    j["scenes"] = Json::array({{{"name", "cityatlas scene"}, {"nodes", Json::array({0})}}});
    const double h = std::sqrt(0.5);
    Json root = {{"name", "local ENU frame (z-up) rotated to glTF y-up"},
                 {"rotation", Json::array({-h, 0.0, 0.0, h})}};

    if (vertices > 0) {
        Json buffer_views = Json::array();
        const uint64_t pos_offset = 0, uv_offset = pos_bytes, feat_offset = pos_bytes + uv_bytes;
        buffer_views.push_back({{"buffer", 0}, {"byteOffset", pos_offset}, {"byteLength", pos_bytes},
                                {"byteStride", 12}, {"target", kArrayBuffer}, {"name", "positions"}});
        const int pos_view = 0;
        int uv_view = -1;
        if (uv_bytes > 0) {
            uv_view = static_cast<int>(buffer_views.size());
            buffer_views.push_back({{"buffer", 0}, {"byteOffset", uv_offset}, {"byteLength", uv_bytes},
                                    {"byteStride", 8}, {"target", kArrayBuffer}, {"name", "texcoords"}});
        }
        const int feat_view = static_cast<int>(buffer_views.size());
        buffer_views.push_back({{"buffer", 0}, {"byteOffset", feat_offset}, {"byteLength", feat_bytes},
                                {"byteStride", 4}, {"target", kArrayBuffer}, {"name", "feature ids"}});

        const fs::path glb_dir = canonicalOrAbsolute(glb_path).parent_path();
        Json accessors = Json::array(), primitives = Json::array(), materials = Json::array();
        Json images = Json::array(), textures = Json::array(), samplers = Json::array();
        std::array<int, 3> sampler_of{-1, -1, -1};  // REPEAT, MIRRORED_REPEAT, CLAMP_TO_EDGE
        uint64_t uv_cursor = 0;
        for (size_t g = 0; g < n_groups; ++g) {
            const Group& gr = groups[g];
            if (gr.triangles == 0) continue;
            const uint64_t count = 3 * gr.triangles;
            Json attributes;
            attributes["POSITION"] = accessors.size();
            accessors.push_back({{"bufferView", pos_view}, {"byteOffset", 3 * gr.first * 12},
                                 {"componentType", kFloat}, {"count", count}, {"type", "VEC3"},
                                 {"min", floats(gr.min)}, {"max", floats(gr.max)}});
            Json material;
            if (g < n_tex) {
                const TextureRef& tex = scene.textures[g];
                attributes["TEXCOORD_0"] = accessors.size();
                accessors.push_back({{"bufferView", uv_view}, {"byteOffset", uv_cursor * 8},
                                     {"componentType", kFloat}, {"count", count}, {"type", "VEC2"}});
                uv_cursor += count;
                const int wrap = samplerWrap(tex.wrap);
                const int slot = wrap == kRepeat ? 0 : wrap == kMirroredRepeat ? 1 : 2;
                if (sampler_of[slot] < 0) {
                    sampler_of[slot] = static_cast<int>(samplers.size());
                    samplers.push_back({{"magFilter", kLinear}, {"minFilter", kLinearMipmapLinear},
                                        {"wrapS", wrap}, {"wrapT", wrap}});
                }
                const size_t image = images.size();
                images.push_back({{"name", fs::path(tex.path).filename().string()},
                                  {"uri", textureUri(tex.path, glb_dir)}});
                const size_t texture = textures.size();
                textures.push_back({{"sampler", sampler_of[slot]}, {"source", image}});
                material = {{"name", fmt::format("texture {}", g)},
                            {"pbrMetallicRoughness",
                             {{"baseColorTexture", {{"index", texture}}}, {"metallicFactor", 0.0},
                              {"roughnessFactor", 1.0}}}};
                if (tex.channels == 4) material["alphaMode"] = "BLEND";
            } else {
                std::array<float, 3> rgb{0.6f, 0.6f, 0.6f};
                float alpha = 1.0f;
                std::string name = "no material (grey)";
                if (g < grey) {
                    const Material& m = scene.materials[g - n_tex];
                    for (int a = 0; a < 3; ++a) rgb[a] = unitClamp(m.diffuse[a]);
                    alpha = 1.0f - unitClamp(m.transparency);
                    name = fmt::format("material {}", g - n_tex);
                }
                material = {{"name", name},
                            {"pbrMetallicRoughness",
                             {{"baseColorFactor", Json::array({static_cast<double>(rgb[0]), static_cast<double>(rgb[1]),
                                                               static_cast<double>(rgb[2]), static_cast<double>(alpha)})},
                              {"metallicFactor", 0.0},
                              {"roughnessFactor", 1.0}}}};
                if (alpha < 1.0f) material["alphaMode"] = "BLEND";
            }
            material["doubleSided"] = false;
            attributes[kGltfFeatureIdAttribute] = accessors.size();
            Json feat = {{"bufferView", feat_view}, {"byteOffset", 3 * gr.first * 4},
                         {"componentType", feature_as_float ? kFloat : kUnsignedInt}, {"count", count},
                         {"type", "SCALAR"}};
            if (feature_as_float) {
                feat["min"] = Json::array({static_cast<double>(static_cast<float>(gr.feature_min))});
                feat["max"] = Json::array({static_cast<double>(static_cast<float>(gr.feature_max))});
            } else {
                feat["min"] = Json::array({gr.feature_min});
                feat["max"] = Json::array({gr.feature_max});
            }
            accessors.push_back(std::move(feat));
            const size_t material_index = materials.size();
            materials.push_back(std::move(material));
            primitives.push_back({{"attributes", std::move(attributes)}, {"material", material_index}});
        }
        root["mesh"] = 0;
        j["meshes"] = Json::array({{{"name", "scene"}, {"primitives", std::move(primitives)}}});
        j["accessors"] = std::move(accessors);
        j["bufferViews"] = std::move(buffer_views);
        j["buffers"] = Json::array({{{"byteLength", bin_bytes}}});
        j["materials"] = std::move(materials);
        if (!images.empty()) {
            j["images"] = std::move(images);
            j["samplers"] = std::move(samplers);
            j["textures"] = std::move(textures);
        }
    }
    j["nodes"] = Json::array({std::move(root)});

    std::string json_text = j.dump(-1, ' ', false, Json::error_handler_t::replace);
    json_text.append((4 - json_text.size() % 4) % 4, ' ');
    const uint64_t total = 12 + 8 + json_text.size() + (bin_bytes > 0 ? 8 + bin_bytes : 0);
    if (total > std::numeric_limits<uint32_t>::max())
        return Status::Fail(fmt::format("{}: {} triangles are too many for one GLB (4 GiB limit)", where, written));

    // --- Counting sort of the written triangles by group. ---
    std::vector<uint32_t> order;
    if (written > 0) {
        if (n_tri > std::numeric_limits<uint32_t>::max())
            return Status::Fail(fmt::format("{}: more than 2^32 triangles", where));
        order.resize(written);
        std::vector<uint64_t> cursor(n_groups);
        for (size_t g = 0; g < n_groups; ++g) cursor[g] = groups[g].first;
        for (size_t i = 0; i < n_tri; ++i)
            if (tri_group[i] != kDropped) order[cursor[tri_group[i]]++] = static_cast<uint32_t>(i);
    }
    std::vector<uint32_t>().swap(tri_group);

    // --- Write to a temporary sibling, then rename into place. ---
    const fs::path tmp = fs::path(glb_path).concat(".partial");
    errno = 0;
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (f == nullptr)
        return Status::Fail(fmt::format("{}: cannot create {}: {}", where, tmp.string(), std::strerror(errno)));
    auto fail = [&](const std::string& why) {
        std::error_code ignored;
        fs::remove(tmp, ignored);
        return Status::Fail(fmt::format("{}: {}", where, why));
    };

    Sink out(f);
    out.u32(kGlbMagic);
    out.u32(2);
    out.u32(static_cast<uint32_t>(total));
    out.u32(static_cast<uint32_t>(json_text.size()));
    out.u32(kChunkJson);
    out.put(json_text.data(), json_text.size());
    if (bin_bytes > 0) {
        out.u32(static_cast<uint32_t>(bin_bytes));
        out.u32(kChunkBin);
        std::array<float, 9> p{};
        for (uint32_t i : order) {
            floatCorners(scene.triangles[i], p);
            out.put(p.data(), sizeof p);
        }
        for (uint32_t i : order) {
            const Triangle& t = scene.triangles[i];
            const int32_t tex = t.texture;
            if (tex < 0 || static_cast<size_t>(tex) >= n_tex || !texture_usable[tex]) continue;  // not textured
            std::array<float, 6> uv{};
            for (int k = 0; k < 3; ++k) {
                uv[2 * k] = finiteOr0(t.uv[k].x);
                uv[2 * k + 1] = finiteOr0(1.0 - t.uv[k].y);
            }
            out.put(uv.data(), sizeof uv);
        }
        for (uint32_t i : order) {
            const uint32_t id = scene.triangles[i].feature;
            if (feature_as_float) {
                const auto v = static_cast<float>(id);
                const std::array<float, 3> ids{v, v, v};
                out.put(ids.data(), sizeof ids);
            } else {
                const std::array<uint32_t, 3> ids{id, id, id};
                out.put(ids.data(), sizeof ids);
            }
        }
    }
    out.flush();
    int err = out.error();
    if (err == 0 && std::fflush(f) != 0) err = errno != 0 ? errno : EIO;
    if (std::fclose(f) != 0 && err == 0) err = errno != 0 ? errno : EIO;
    if (err != 0) return fail(fmt::format("cannot write {}: {}", tmp.string(), std::strerror(err)));

    std::error_code ec;
    fs::rename(tmp, glb_path, ec);
    if (ec) return fail(fmt::format("cannot rename {} into place: {}", tmp.string(), ec.message()));
    return Status::Ok();
}

}  // namespace cityatlas
