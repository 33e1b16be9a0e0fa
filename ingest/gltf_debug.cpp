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
#include <iterator>
#include <limits>
#include <memory>
#include <string>
#include <system_error>
#include <unordered_map>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cityatlas_version.h"

namespace cityatlas {
namespace {

namespace fs = std::filesystem;

static_assert(std::endian::native == std::endian::little, "GLB is little-endian; add byte swapping");

constexpr uint32_t kDropped = std::numeric_limits<uint32_t>::max();

// glTF enums.
constexpr int kFloat = 5126;
constexpr int kUnsignedShort = 5123;
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

// Feature ids up to 2^24 are exact in float32, which every viewer can read. glTF
// forbids UNSIGNED_INT for vertex attributes (the validator reports
// MESH_PRIMITIVE_ATTRIBUTES_ACCESSOR_UNSIGNED_INT), so a scene with a larger id
// (never seen in practice) gets the attribute as VEC2 UNSIGNED_SHORT (low 16
// bits, high 16 bits) instead; asset.extras.feature_id_encoding says which.
constexpr uint32_t kMaxExactFloatInt = 1u << 24;


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

fs::path absoluteOr(const fs::path& p) {
    std::error_code ec;
    fs::path abs = fs::absolute(p, ec);
    return ec ? p : abs;
}

fs::path canonicalOrAbsolute(const fs::path& p) {
    std::error_code ec;
    const fs::path abs = absoluteOr(p);
    fs::path canon = fs::weakly_canonical(abs, ec);
    return ec ? abs.lexically_normal() : canon;
}

// URIs of texture files as seen from the folder of the .glb. Folders are
// resolved (symlinks, "..") once each: textures share a few folders, and
// resolving every file costs ~10 us of system calls.
class TextureUris {
  public:
    // The folder, not the file, is resolved: the .glb replaces whatever is at
    // glb_path (a symlink too), so URIs are relative to where that entry lives.
    explicit TextureUris(const fs::path& glb_path)
        : glb_dir_(canonicalOrAbsolute(absoluteOr(glb_path).parent_path())) {}

    std::string uri(const std::string& texture_path) {
        const fs::path abs = absoluteOr(texture_path).lexically_normal();
        const std::string dir_key = abs.parent_path().string();
        auto it = dirs_.find(dir_key);
        if (it == dirs_.end()) it = dirs_.emplace(dir_key, canonicalOrAbsolute(abs.parent_path())).first;
        const fs::path tex = it->second / abs.filename();
        const fs::path rel = tex.lexically_relative(glb_dir_);
        if (!rel.empty() && rel != ".") return percentEncodePath(rel.generic_string());
        // No relative form (cannot happen for two absolute POSIX paths unless the
        // texture IS the folder): an absolute file URI.
        return "file://" + percentEncodePath(tex.generic_string());
    }

  private:
    fs::path glb_dir_;
    std::unordered_map<std::string, fs::path> dirs_;  ///< per folder, not per texture
};

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

// A JSON string literal: escaped, invalid UTF-8 replaced (U+FFFD).
std::string jsonString(const std::string& s) {
    return nlohmann::json(s).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

// A float32 value as the double it is exactly. fmt prints a float in the shortest
// form that reads back as that FLOAT ("0.1"), which a reader parsing into double
// gets as 0.1, not as 0.1f: accessor min/max must equal the data exactly, so
// floats are printed through double (shortest form that reads back as the double).
double asDouble(float v) { return static_cast<double>(v); }

// A JSON number (shortest round-trip form), or null when not finite.
std::string jsonNumber(double v) { return std::isfinite(v) ? fmt::format("{}", v) : "null"; }

}  // namespace

Status writeDebugGlb(const Scene& scene, const std::filesystem::path& glb_path) {
    const std::string where = glb_path.string();
    if (glb_path.empty() || !glb_path.has_filename())
        return Status::Io(fmt::format("{}: not a file name for the debug glb", where));

    // --- Classify: group of every triangle (texture, then material, then grey). ---
    const size_t n_tex = scene.textures.size();
    const size_t n_mat = scene.materials.size();
    const size_t n_groups = n_tex + n_mat + 1;
    const size_t grey = n_tex + n_mat;
    if (n_groups >= kDropped) return Status::Io(fmt::format("{}: too many textures and materials", where));
    std::vector<bool> texture_usable(n_tex);
    for (size_t i = 0; i < n_tex; ++i) texture_usable[i] = !scene.textures.path(i).empty();

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
        return Status::Io(fmt::format("{}: {} triangles are too many for one GLB (4 GiB limit)", where, written));

    // --- JSON, emitted as text (an nlohmann DOM cost ~27 us per texture, this ~3). ---
    std::string json_text;
    json_text.reserve(1024 + 700 * n_tex);
    auto js = std::back_inserter(json_text);
    fmt::format_to(js,
                   R"({{"asset":{{"version":"2.0","generator":{},"extras":{{"source_crs":{},"origin_source":[{},{},{}],)"
                   R"("frame":"positions in local east/north/up metres relative to origin_source; the root node rotates )"
                   R"(z-up to y-up","triangles":{},"dropped_triangles":{},"feature_id_encoding":"{}"}}}},)",
                   jsonString(fmt::format("cityatlas {} (debug view of a Scene)", kCityAtlasVersion)),
                   jsonString(scene.georef.source_crs), jsonNumber(scene.georef.origin_source.x),
                   jsonNumber(scene.georef.origin_source.y), jsonNumber(scene.georef.origin_source.z), written,
                   dropped, feature_as_float ? "float" : "uint16 pair (low, high)");
    fmt::format_to(js, R"("scene":0,"scenes":[{{"name":"cityatlas scene","nodes":[0]}}],)");
    // Rotation -90 degrees about x: glTF (x, y, z) = (east, up, -north).
    const double h = std::sqrt(0.5);
    fmt::format_to(js, R"("nodes":[{{"name":"local ENU frame (z-up) rotated to glTF y-up","rotation":[{},0,0,{}]{}}}])",
                   -h, h, vertices > 0 ? R"(,"mesh":0)" : "");

    if (vertices > 0) {
        const uint64_t uv_offset = pos_bytes, feat_offset = pos_bytes + uv_bytes;
        std::string views = fmt::format(
            R"({{"buffer":0,"byteOffset":0,"byteLength":{},"byteStride":12,"target":{},"name":"positions"}})", pos_bytes,
            kArrayBuffer);
        const int pos_view = 0;
        int uv_view = -1, feat_view = 1;
        if (uv_bytes > 0) {
            uv_view = 1, feat_view = 2;
            fmt::format_to(std::back_inserter(views),
                           R"(,{{"buffer":0,"byteOffset":{},"byteLength":{},"byteStride":8,"target":{},"name":"texcoords"}})",
                           uv_offset, uv_bytes, kArrayBuffer);
        }
        fmt::format_to(std::back_inserter(views),
                       R"(,{{"buffer":0,"byteOffset":{},"byteLength":{},"byteStride":4,"target":{},"name":"feature ids"}})",
                       feat_offset, feat_bytes, kArrayBuffer);

        TextureUris uris(glb_path);
        std::string accessors, primitives, materials, images, textures, samplers;
        auto acc = std::back_inserter(accessors), prim = std::back_inserter(primitives);
        auto mat = std::back_inserter(materials);
        size_t n_accessors = 0, n_materials = 0, n_images = 0, n_samplers = 0;
        auto sep = [](std::string& list) {
            if (!list.empty()) list += ',';
        };
        std::array<int, 3> sampler_of{-1, -1, -1};  // REPEAT, MIRRORED_REPEAT, CLAMP_TO_EDGE
        uint64_t uv_cursor = 0;
        for (size_t g = 0; g < n_groups; ++g) {
            const Group& gr = groups[g];
            if (gr.triangles == 0) continue;
            const uint64_t count = 3 * gr.triangles;

            sep(accessors);
            const size_t position_accessor = n_accessors++;
            fmt::format_to(acc,
                           R"({{"bufferView":{},"byteOffset":{},"componentType":{},"count":{},"type":"VEC3",)"
                           R"("min":[{},{},{}],"max":[{},{},{}]}})",
                           pos_view, 3 * gr.first * 12, kFloat, count, asDouble(gr.min[0]), asDouble(gr.min[1]),
                           asDouble(gr.min[2]), asDouble(gr.max[0]), asDouble(gr.max[1]), asDouble(gr.max[2]));
            sep(primitives);
            fmt::format_to(prim, R"({{"attributes":{{"POSITION":{})", position_accessor);
            sep(materials);
            if (g < n_tex) {
                const TextureRef tex = scene.textures.ref(g);
                fmt::format_to(acc, R"(,{{"bufferView":{},"byteOffset":{},"componentType":{},"count":{},"type":"VEC2"}})",
                               uv_view, uv_cursor * 8, kFloat, count);
                fmt::format_to(prim, R"(,"TEXCOORD_0":{})", n_accessors++);
                uv_cursor += count;
                const int wrap = gltfSamplerWrap(tex.wrap);
                const int slot = wrap == kRepeat ? 0 : wrap == kMirroredRepeat ? 1 : 2;
                if (sampler_of[slot] < 0) {
                    sampler_of[slot] = static_cast<int>(n_samplers++);
                    sep(samplers);
                    fmt::format_to(std::back_inserter(samplers),
                                   R"({{"magFilter":{},"minFilter":{},"wrapS":{},"wrapT":{}}})", kLinear,
                                   kLinearMipmapLinear, wrap, wrap);
                }
                // One image and one texture per TextureRef used, at the same index.
                sep(images);
                fmt::format_to(std::back_inserter(images), R"({{"name":{},"uri":"{}"}})",
                               jsonString(fs::path(tex.path).filename().string()), uris.uri(tex.path));
                sep(textures);
                fmt::format_to(std::back_inserter(textures), R"({{"sampler":{},"source":{}}})", sampler_of[slot],
                               n_images);
                fmt::format_to(mat,
                               R"({{"name":"texture {}","pbrMetallicRoughness":{{"baseColorTexture":{{"index":{}}},)"
                               R"("metallicFactor":0,"roughnessFactor":1}}{},"doubleSided":false}})",
                               g, n_images, tex.channels == 4 ? R"(,"alphaMode":"BLEND")" : "");
                ++n_images;
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
                fmt::format_to(mat,
                               R"({{"name":"{}","pbrMetallicRoughness":{{"baseColorFactor":[{},{},{},{}],)"
                               R"("metallicFactor":0,"roughnessFactor":1}}{},"doubleSided":false}})",
                               name, asDouble(rgb[0]), asDouble(rgb[1]), asDouble(rgb[2]), asDouble(alpha),
                               alpha < 1.0f ? R"(,"alphaMode":"BLEND")" : "");
            }
            if (feature_as_float) {
                fmt::format_to(acc,
                               R"(,{{"bufferView":{},"byteOffset":{},"componentType":{},"count":{},"type":"SCALAR",)"
                               R"("min":[{}],"max":[{}]}})",
                               feat_view, 3 * gr.first * 4, kFloat, count, asDouble(static_cast<float>(gr.feature_min)),
                               asDouble(static_cast<float>(gr.feature_max)));
            } else {
                fmt::format_to(acc, R"(,{{"bufferView":{},"byteOffset":{},"componentType":{},"count":{},"type":"VEC2"}})",
                               feat_view, 3 * gr.first * 4, kUnsignedShort, count);
            }
            fmt::format_to(prim, R"(,"{}":{}}},"material":{}}})", kGltfFeatureIdAttribute, n_accessors++,
                           n_materials++);
        }
        fmt::format_to(js, R"(,"meshes":[{{"name":"scene","primitives":[{}]}}],"accessors":[{}],"bufferViews":[{}],)"
                            R"("buffers":[{{"byteLength":{}}}],"materials":[{}])",
                       primitives, accessors, views, bin_bytes, materials);
        if (n_images > 0)
            fmt::format_to(js, R"(,"images":[{}],"samplers":[{}],"textures":[{}])", images, samplers, textures);
    }
    json_text += '}';
    json_text.append((4 - json_text.size() % 4) % 4, ' ');
    const uint64_t total = 12 + 8 + json_text.size() + (bin_bytes > 0 ? 8 + bin_bytes : 0);
    if (total > std::numeric_limits<uint32_t>::max())
        return Status::Io(fmt::format("{}: {} triangles are too many for one GLB (4 GiB limit)", where, written));

    // --- Counting sort of the written triangles by group. ---
    std::vector<uint32_t> order;
    if (written > 0) {
        if (n_tri > std::numeric_limits<uint32_t>::max())
            return Status::Io(fmt::format("{}: more than 2^32 triangles", where));
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
        return Status::Io(fmt::format("{}: cannot create {}: {}", where, tmp.string(), std::strerror(errno)));
    auto fail = [&](const std::string& why) {
        std::error_code ignored;
        fs::remove(tmp, ignored);
        return Status::Io(fmt::format("{}: {}", where, why));
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
                const auto lo = static_cast<uint16_t>(id & 0xFFFFu), hi = static_cast<uint16_t>(id >> 16);
                const std::array<uint16_t, 6> ids{lo, hi, lo, hi, lo, hi};
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

int gltfSamplerWrap(WrapMode w) {
    switch (w) {
        case WrapMode::Wrap: return kRepeat;
        case WrapMode::Mirror: return kMirroredRepeat;
        case WrapMode::Clamp:
        case WrapMode::Border:
        case WrapMode::None: break;
    }
    return kClampToEdge;
}

}  // namespace cityatlas
