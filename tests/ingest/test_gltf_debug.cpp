// SPDX-License-Identifier: GPL-3.0-or-later
// writeDebugGlb: the written .glb is read back with tinygltf (an independent
// reader) and compared with the Scene, triangle by triangle.

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include "ingest/gltf_debug.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"

namespace fs = std::filesystem;
using namespace cityatlas;

namespace {

constexpr int kRepeat = 10497, kMirroredRepeat = 33648, kClampToEdge = 33071;
constexpr int kFloat = 5126, kUnsignedShort = 5123;

// Images point at PNG files by URI: tinygltf must not try to decode them.
bool noDecode(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
    return true;
}

class GltfDebug : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("cityatlas_gltf_debug_" + std::to_string(::getpid()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    static tinygltf::Model load(const fs::path& glb) {
        tinygltf::TinyGLTF loader;
        loader.SetImageLoader(noDecode, nullptr);
        tinygltf::Model model;
        std::string err, warn;
        const bool ok = loader.LoadBinaryFromFile(&model, &err, &warn, glb.string());
        EXPECT_TRUE(ok) << err;
        EXPECT_TRUE(err.empty()) << err;
        return model;
    }

    static std::vector<std::string> listDir(const fs::path& d) {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(d)) names.push_back(e.path().filename().string());
        std::sort(names.begin(), names.end());
        return names;
    }

    fs::path dir_;
};

// Elements of an accessor as `components` values of type T each (honours byteStride).
template <class T>
std::vector<T> readAccessor(const tinygltf::Model& m, int index, int components) {
    std::vector<T> out;
    if (index < 0 || static_cast<size_t>(index) >= m.accessors.size()) {
        ADD_FAILURE() << "no accessor " << index;
        return out;
    }
    const tinygltf::Accessor& a = m.accessors[index];
    const tinygltf::BufferView& v = m.bufferViews.at(a.bufferView);
    const tinygltf::Buffer& b = m.buffers.at(v.buffer);
    const size_t elem = sizeof(T) * components;
    const size_t stride = v.byteStride != 0 ? v.byteStride : elem;
    const size_t start = v.byteOffset + a.byteOffset;
    if (a.count > 0 && start + stride * (a.count - 1) + elem > v.byteOffset + v.byteLength) {
        ADD_FAILURE() << "accessor " << index << " runs past its bufferView";
        return out;
    }
    if (v.byteOffset + v.byteLength > b.data.size()) {
        ADD_FAILURE() << "bufferView past the buffer";
        return out;
    }
    out.resize(a.count * components);
    for (size_t i = 0; i < a.count; ++i) std::memcpy(&out[i * components], &b.data[start + i * stride], elem);
    return out;
}

// Percent-decoding of a URI path (what a viewer does before opening the file).
std::string percentDecode(const std::string& s) {
    std::string out;
    for (size_t i = 0; i < s.size(); ++i) {
        if (s[i] == '%' && i + 2 < s.size()) {
            out += static_cast<char>(std::stoi(s.substr(i + 1, 2), nullptr, 16));
            i += 2;
        } else {
            out += s[i];
        }
    }
    return out;
}

// Key of the primitive a triangle belongs to, as writeDebugGlb documents it:
// textures first (index order), then materials, then the grey fallback.
size_t groupOf(const Scene& s, const Triangle& t) {
    if (t.texture >= 0 && static_cast<size_t>(t.texture) < s.textures.size() && !s.textures.path(t.texture).empty())
        return static_cast<size_t>(t.texture);
    if (t.material >= 0 && static_cast<size_t>(t.material) < s.materials.size())
        return s.textures.size() + static_cast<size_t>(t.material);
    return s.textures.size() + s.materials.size();
}

bool finiteAsFloat(const Triangle& t) {
    for (const Vec3d& p : t.position_local)
        for (double v : {p.x, p.y, p.z})
            if (!std::isfinite(static_cast<float>(v))) return false;
    return true;
}

// Rotates v by the unit quaternion q = (x, y, z, w).
std::array<double, 3> rotate(const std::vector<double>& q, const std::array<double, 3>& v) {
    const double qx = q[0], qy = q[1], qz = q[2], qw = q[3];
    // t = 2 * cross(q.xyz, v); v' = v + w * t + cross(q.xyz, t)
    const double tx = 2 * (qy * v[2] - qz * v[1]);
    const double ty = 2 * (qz * v[0] - qx * v[2]);
    const double tz = 2 * (qx * v[1] - qy * v[0]);
    return {v[0] + qw * tx + (qy * tz - qz * ty), v[1] + qw * ty + (qz * tx - qx * tz),
            v[2] + qw * tz + (qx * ty - qy * tx)};
}

// Checks the whole file against the scene: one primitive per group used, in
// order; every kept triangle's corners (exact float32, and through the root
// rotation in y-up), uvs (v flipped), feature ids; POSITION min/max.
void expectMatchesScene(const tinygltf::Model& m, const Scene& scene, const fs::path& glb) {
    const size_t n_groups = scene.textures.size() + scene.materials.size() + 1;
    std::vector<std::vector<size_t>> members(n_groups);
    size_t kept = 0;
    for (size_t i = 0; i < scene.triangles.size(); ++i) {
        if (!finiteAsFloat(scene.triangles[i])) continue;
        members[groupOf(scene, scene.triangles[i])].push_back(i);
        ++kept;
    }
    std::vector<size_t> used;
    for (size_t g = 0; g < n_groups; ++g)
        if (!members[g].empty()) used.push_back(g);

    ASSERT_EQ(m.scenes.size(), 1u);
    ASSERT_EQ(m.nodes.size(), 1u);
    const tinygltf::Node& root = m.nodes[0];
    ASSERT_EQ(root.rotation.size(), 4u);
    const double h = std::sqrt(0.5);
    EXPECT_NEAR(root.rotation[0], -h, 1e-12);
    EXPECT_NEAR(root.rotation[1], 0, 1e-12);
    EXPECT_NEAR(root.rotation[2], 0, 1e-12);
    EXPECT_NEAR(root.rotation[3], h, 1e-12);
    EXPECT_TRUE(root.translation.empty());
    EXPECT_TRUE(root.scale.empty());
    EXPECT_NE(m.asset.generator.find("cityatlas"), std::string::npos) << m.asset.generator;

    if (kept == 0) {
        EXPECT_TRUE(m.meshes.empty());
        EXPECT_EQ(root.mesh, -1);
        return;
    }
    ASSERT_EQ(root.mesh, 0);
    ASSERT_EQ(m.meshes.size(), 1u);
    const auto& prims = m.meshes[0].primitives;
    ASSERT_EQ(prims.size(), used.size()) << "one primitive per texture/material used";

    const fs::path glb_dir = fs::absolute(glb).parent_path();
    size_t triangles_in_file = 0;
    for (size_t p = 0; p < prims.size(); ++p) {
        SCOPED_TRACE("primitive " + std::to_string(p));
        const tinygltf::Primitive& prim = prims[p];
        const size_t g = used[p];
        const std::vector<size_t>& tris = members[g];
        EXPECT_EQ(prim.mode, TINYGLTF_MODE_TRIANGLES);
        EXPECT_EQ(prim.indices, -1);
        ASSERT_TRUE(prim.attributes.count("POSITION"));
        ASSERT_TRUE(prim.attributes.count(kGltfFeatureIdAttribute));
        const tinygltf::Accessor& pa = m.accessors.at(prim.attributes.at("POSITION"));
        ASSERT_EQ(pa.componentType, kFloat);
        ASSERT_EQ(pa.type, TINYGLTF_TYPE_VEC3);
        ASSERT_EQ(pa.count, 3 * tris.size());
        triangles_in_file += pa.count / 3;

        const std::vector<float> pos = readAccessor<float>(m, prim.attributes.at("POSITION"), 3);
        ASSERT_EQ(pos.size(), 9 * tris.size());
        std::array<float, 3> mn{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                                std::numeric_limits<float>::max()};
        std::array<float, 3> mx{std::numeric_limits<float>::lowest(), std::numeric_limits<float>::lowest(),
                                std::numeric_limits<float>::lowest()};
        for (size_t t = 0; t < tris.size(); ++t) {
            const Triangle& tri = scene.triangles[tris[t]];
            for (int k = 0; k < 3; ++k) {
                const Vec3d& q = tri.position_local[k];
                const float* f = &pos[9 * t + 3 * k];
                // Stored: the local frame as float32, exactly.
                ASSERT_EQ(f[0], static_cast<float>(q.x));
                ASSERT_EQ(f[1], static_cast<float>(q.y));
                ASSERT_EQ(f[2], static_cast<float>(q.z));
                // Seen by a viewer: y-up (x, y, z) = (east, up, -north), within float precision.
                const auto yup = rotate(root.rotation, {f[0], f[1], f[2]});
                const std::array<double, 3> want{q.x, q.z, -q.y};
                for (int a = 0; a < 3; ++a) {
                    const double tol = 1e-6 * std::max(1.0, std::abs(want[a])) + 1e-9 * std::abs(f[0] + f[1] + f[2]);
                    ASSERT_NEAR(yup[a], want[a], tol) << "triangle " << tris[t] << " corner " << k << " axis " << a;
                }
                for (int a = 0; a < 3; ++a) {
                    mn[a] = std::min(mn[a], f[a]);
                    mx[a] = std::max(mx[a], f[a]);
                }
            }
        }
        ASSERT_EQ(pa.minValues.size(), 3u);
        ASSERT_EQ(pa.maxValues.size(), 3u);
        for (int a = 0; a < 3; ++a) {
            EXPECT_EQ(pa.minValues[a], static_cast<double>(mn[a]));
            EXPECT_EQ(pa.maxValues[a], static_cast<double>(mx[a]));
        }

        // Feature ids, per vertex.
        const tinygltf::Accessor& fa = m.accessors.at(prim.attributes.at(kGltfFeatureIdAttribute));
        ASSERT_EQ(fa.count, pa.count);
        if (fa.componentType == kFloat) {
            ASSERT_EQ(fa.type, TINYGLTF_TYPE_SCALAR);
            const std::vector<float> ids = readAccessor<float>(m, prim.attributes.at(kGltfFeatureIdAttribute), 1);
            ASSERT_EQ(ids.size(), 3 * tris.size());
            for (size_t t = 0; t < tris.size(); ++t)
                for (int k = 0; k < 3; ++k)
                    ASSERT_EQ(ids[3 * t + k], static_cast<float>(scene.triangles[tris[t]].feature));
            // min/max are optional here, but when present the validator checks them.
            if (!fa.minValues.empty() || !fa.maxValues.empty()) {
                ASSERT_EQ(fa.minValues.size(), 1u);
                ASSERT_EQ(fa.maxValues.size(), 1u);
                EXPECT_EQ(fa.minValues[0], *std::min_element(ids.begin(), ids.end()));
                EXPECT_EQ(fa.maxValues[0], *std::max_element(ids.begin(), ids.end()));
            }
        } else {
            ASSERT_EQ(fa.componentType, kUnsignedShort);
            ASSERT_EQ(fa.type, TINYGLTF_TYPE_VEC2);
            const std::vector<uint16_t> ids = readAccessor<uint16_t>(m, prim.attributes.at(kGltfFeatureIdAttribute), 2);
            ASSERT_EQ(ids.size(), 6 * tris.size());
            for (size_t t = 0; t < tris.size(); ++t)
                for (int k = 0; k < 3; ++k)
                    ASSERT_EQ(ids[6 * t + 2 * k] | (uint32_t{ids[6 * t + 2 * k + 1]} << 16),
                              scene.triangles[tris[t]].feature);
        }

        // Material.
        ASSERT_GE(prim.material, 0);
        const tinygltf::Material& mat = m.materials.at(prim.material);
        EXPECT_FALSE(mat.doubleSided);
        if (g < scene.textures.size()) {
            const TextureRef ref = scene.textures.ref(g);
            const int ti = mat.pbrMetallicRoughness.baseColorTexture.index;
            ASSERT_GE(ti, 0);
            const tinygltf::Texture& tex = m.textures.at(ti);
            const tinygltf::Image& img = m.images.at(tex.source);
            EXPECT_EQ(img.bufferView, -1) << "images are referenced, never embedded";
            EXPECT_TRUE(img.mimeType.empty()) << img.mimeType;
            EXPECT_EQ(img.uri.find(' '), std::string::npos) << img.uri;
            EXPECT_EQ(img.uri.find('\\'), std::string::npos) << img.uri;
            ASSERT_FALSE(img.uri.empty());
            EXPECT_NE(img.uri.front(), '/') << "relative URI expected: " << img.uri;
            EXPECT_EQ(img.uri.find(':'), std::string::npos) << "relative URI expected: " << img.uri;
            EXPECT_TRUE(fs::equivalent(glb_dir / percentDecode(img.uri), ref.path))
                << img.uri << " does not lead to " << ref.path;
            ASSERT_GE(tex.sampler, 0);
            const tinygltf::Sampler& s = m.samplers.at(tex.sampler);
            const int want = ref.wrap == WrapMode::Wrap ? kRepeat
                             : ref.wrap == WrapMode::Mirror ? kMirroredRepeat
                                                            : kClampToEdge;
            EXPECT_EQ(s.wrapS, want);
            EXPECT_EQ(s.wrapT, want);
            EXPECT_EQ(mat.alphaMode, ref.channels == 4 ? "BLEND" : "OPAQUE");

            ASSERT_TRUE(prim.attributes.count("TEXCOORD_0"));
            const std::vector<float> uv = readAccessor<float>(m, prim.attributes.at("TEXCOORD_0"), 2);
            ASSERT_EQ(uv.size(), 6 * tris.size());
            for (size_t t = 0; t < tris.size(); ++t) {
                const Triangle& tri = scene.triangles[tris[t]];
                for (int k = 0; k < 3; ++k) {
                    ASSERT_EQ(uv[6 * t + 2 * k], static_cast<float>(tri.uv[k].x));
                    ASSERT_EQ(uv[6 * t + 2 * k + 1], static_cast<float>(1.0 - tri.uv[k].y)) << "v is flipped";
                }
            }
        } else {
            EXPECT_EQ(mat.pbrMetallicRoughness.baseColorTexture.index, -1);
            EXPECT_FALSE(prim.attributes.count("TEXCOORD_0"));
            const auto& f = mat.pbrMetallicRoughness.baseColorFactor;
            ASSERT_EQ(f.size(), 4u);
            if (g < scene.textures.size() + scene.materials.size()) {
                const Material& sm = scene.materials[g - scene.textures.size()];
                for (int a = 0; a < 3; ++a) EXPECT_FLOAT_EQ(f[a], std::clamp(sm.diffuse[a], 0.0f, 1.0f));
                EXPECT_FLOAT_EQ(f[3], 1.0f - std::clamp(sm.transparency, 0.0f, 1.0f));
                EXPECT_EQ(mat.alphaMode, sm.transparency > 0 ? "BLEND" : "OPAQUE");
            } else {
                // Neutral grey, opaque.
                EXPECT_EQ(f[0], f[1]);
                EXPECT_EQ(f[1], f[2]);
                EXPECT_GT(f[0], 0.2);
                EXPECT_LT(f[0], 0.9);
                EXPECT_EQ(f[3], 1.0);
                EXPECT_EQ(mat.alphaMode, "OPAQUE");
            }
        }
    }
    EXPECT_EQ(triangles_in_file, kept);
}

Triangle tri(Vec3d a, Vec3d b, Vec3d c, int32_t texture, int32_t material, uint32_t feature) {
    Triangle t;
    t.position_local = {a, b, c};
    t.uv = {Vec2d{0, 0}, Vec2d{1, 0}, Vec2d{0.25, 1}};
    t.texture = texture;
    t.material = material;
    t.feature = feature;
    return t;
}

// "t3.png" (snprintf: string concatenation here trips GCC 12's -Wrestrict false
// positive at -O3, GCC bug 105329).
std::string numbered(const char* prefix, size_t i, const char* suffix) {
    char buf[256];
    std::snprintf(buf, sizeof buf, "%s%zu%s", prefix, i, suffix);
    return buf;
}

// Changes the current directory for its lifetime.
class CurrentDir {
public:
    explicit CurrentDir(const fs::path& d) : before_(fs::current_path()) { fs::current_path(d); }
    ~CurrentDir() { fs::current_path(before_); }
    CurrentDir(const CurrentDir&) = delete;
    CurrentDir& operator=(const CurrentDir&) = delete;

private:
    fs::path before_;
};

void writeFile(const fs::path& p, const std::string& bytes) {
    fs::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << bytes;
}

}  // namespace

TEST_F(GltfDebug, SyntheticTownRoundTrips) {
    synth::TownSettings settings;
    settings.buildings = 14;  // building 7 and 14 have RGBA facades
    settings.texture_size_px = 16;
    const synth::Town town = synth::generateTown(settings);
    const fs::path town_dir = dir_ / "town";
    ASSERT_TRUE(synth::writeTown(town, town_dir, false, nullptr).ok());
    const Scene scene = synth::townToScene(town, town_dir);
    ASSERT_GT(scene.triangles.size(), 100u);

    const fs::path glb = dir_ / "debug.glb";
    const Status st = writeDebugGlb(scene, glb);
    ASSERT_TRUE(st.ok()) << st.error;
    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, scene, glb);

    // The synthetic town uses textures and (for untextured roofs) materials, and
    // has RGBA facades; make sure all of that was exercised.
    bool blend = false, untextured = false;
    for (const auto& mat : m.materials) {
        blend = blend || mat.alphaMode == "BLEND";
        untextured = untextured || mat.pbrMetallicRoughness.baseColorTexture.index < 0;
    }
    EXPECT_TRUE(blend);
    EXPECT_TRUE(untextured);
    // URIs are relative to the glb: textures sit in town/textures/.
    for (const auto& img : m.images) EXPECT_EQ(img.uri.rfind("town/textures/", 0), 0u) << img.uri;
    EXPECT_EQ(listDir(dir_), (std::vector<std::string>{"debug.glb", "town"})) << "temporary file left behind";
}

TEST_F(GltfDebug, SamplersFollowWrapModes) {
    Scene s;
    const std::array<WrapMode, 5> modes{WrapMode::Wrap, WrapMode::Mirror, WrapMode::Clamp, WrapMode::Border,
                                        WrapMode::None};
    for (size_t i = 0; i < modes.size(); ++i) {
        const fs::path p = dir_ / "tex" / numbered("t", i, ".png");
        writeFile(p, "not decoded");
        s.textures.push_back({p.string(), 8, 8, i == 1 ? 4 : 3, modes[i]});
        s.triangles.push_back(tri({0, 0, double(i)}, {1, 0, double(i)}, {0, 1, double(i)}, int32_t(i), -1, uint32_t(i)));
    }
    const fs::path glb = dir_ / "s.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, s, glb);
    EXPECT_EQ(m.samplers.size(), 3u) << "REPEAT, MIRRORED_REPEAT and CLAMP_TO_EDGE, each once";
}

TEST_F(GltfDebug, MaterialsGreyAndTransparency) {
    Scene s;
    s.materials.push_back({{0.9f, 0.1f, 0.2f}, 0.0f});
    s.materials.push_back({{0.2f, 0.4f, 0.8f}, 0.5f});
    s.materials.push_back({{1.5f, -0.5f, 0.5f}, 0.0f});  // out of range: clamped
    s.materials.push_back({{0.3f, 0.3f, 0.3f}, 0.0f});   // unused: no primitive
    // Interleaved on purpose: the writer groups them.
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, 1, 5));
    s.triangles.push_back(tri({0, 0, 1}, {1, 0, 1}, {0, 1, 1}, -1, 0, 6));
    s.triangles.push_back(tri({0, 0, 2}, {1, 0, 2}, {0, 1, 2}, -1, -1, 7));  // grey
    s.triangles.push_back(tri({0, 0, 3}, {1, 0, 3}, {0, 1, 3}, -1, 1, 8));
    s.triangles.push_back(tri({0, 0, 4}, {1, 0, 4}, {0, 1, 4}, 3, 2, 9));    // texture index out of range
    s.triangles.push_back(tri({0, 0, 5}, {1, 0, 5}, {0, 1, 5}, -1, 99, 10)); // material out of range: grey
    const fs::path glb = dir_ / "m.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, s, glb);
    ASSERT_EQ(m.meshes.at(0).primitives.size(), 4u);  // materials 0, 1, 2 and grey
    EXPECT_TRUE(m.images.empty());
    EXPECT_TRUE(m.textures.empty());
}

TEST_F(GltfDebug, InexactCoordinatesRoundTrip) {
    // Values that are not exact in float32 (nor in binary): POSITION min/max
    // must still equal the stored floats exactly, and the colours read back.
    Scene s;
    s.materials.push_back({{0.1f, 0.7f, 1.0f / 3}, 0.3f});
    s.triangles.push_back(tri({0.1, 1.0 / 3, -0.7}, {2.2, -1.0 / 7, 0.3}, {0.6, 1e-3, 1.0 / 9}, -1, 0, 1));
    s.triangles.push_back(tri({691234.567, 5336789.123, 512.3}, {-3.3e-5, 7.77, 1e7 / 3}, {1e-30, -0.2, 0.4}, -1, 0, 2));
    Triangle t = tri({0.3, 0.2, 0.1}, {0.9, 0.8, 0.7}, {-0.1, -0.2, -0.3}, -1, -1, 3);
    s.triangles.push_back(t);
    const fs::path glb = dir_ / "inexact.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    expectMatchesScene(load(glb), s, glb);
}

TEST_F(GltfDebug, NonFiniteTrianglesAreDropped) {
    Scene s;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 0));
    s.triangles.push_back(tri({nan, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 1));
    s.triangles.push_back(tri({0, 0, 0}, {1, inf, 0}, {0, 1, 0}, -1, -1, 2));
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, -1e300}, -1, -1, 3));  // finite, but not as float
    s.triangles.push_back(tri({5, 5, 5}, {5, 5, 5}, {5, 5, 5}, -1, -1, 4));       // degenerate: kept
    Triangle bad_uv = tri({0, 0, 9}, {1, 0, 9}, {0, 1, 9}, -1, -1, 5);
    bad_uv.uv[1] = {nan, inf};  // untextured: uvs are not written at all
    s.triangles.push_back(bad_uv);
    const fs::path glb = dir_ / "nf.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, s, glb);
    const auto& prims = m.meshes.at(0).primitives;
    ASSERT_EQ(prims.size(), 1u);
    EXPECT_EQ(m.accessors.at(prims[0].attributes.at("POSITION")).count, 9u);  // 3 triangles kept
    for (float v : readAccessor<float>(m, prims[0].attributes.at("POSITION"), 3)) EXPECT_TRUE(std::isfinite(v));
    ASSERT_TRUE(m.asset.extras.Has("dropped_triangles"));
    EXPECT_EQ(m.asset.extras.Get("dropped_triangles").GetNumberAsInt(), 3);
}

TEST_F(GltfDebug, NonFiniteTexcoordsBecomeZero) {
    Scene s;
    const fs::path p = dir_ / "a.png";
    writeFile(p, "x");
    s.textures.push_back({p.string(), 4, 4, 3, WrapMode::Wrap});
    Triangle t = tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, -1, 0);
    t.uv[1] = {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()};
    s.triangles.push_back(t);
    const fs::path glb = dir_ / "uv.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    const tinygltf::Model m = load(glb);
    const std::vector<float> uv = readAccessor<float>(m, m.meshes.at(0).primitives.at(0).attributes.at("TEXCOORD_0"), 2);
    ASSERT_EQ(uv.size(), 6u);
    for (float v : uv) EXPECT_TRUE(std::isfinite(v));
    EXPECT_EQ(uv[2], 0.0f);
    EXPECT_EQ(uv[3], 0.0f);
    EXPECT_EQ(uv[1], 1.0f);  // v = 0 -> 1
}

TEST_F(GltfDebug, LargeFeatureIdsStayExact) {
    Scene s;
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 16777217u));  // 2^24 + 1: not a float
    s.triangles.push_back(tri({0, 0, 1}, {1, 0, 1}, {0, 1, 1}, -1, -1, 0xFFFFFFFFu));
    s.triangles.push_back(tri({0, 0, 2}, {1, 0, 2}, {0, 1, 2}, -1, -1, 3u));
    const fs::path glb = dir_ / "f.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, s, glb);
    const auto& a = m.accessors.at(m.meshes.at(0).primitives.at(0).attributes.at(kGltfFeatureIdAttribute));
    EXPECT_EQ(a.componentType, kUnsignedShort);
    EXPECT_EQ(m.asset.extras.Get("feature_id_encoding").Get<std::string>(), "uint16 pair (low, high)");
}

TEST_F(GltfDebug, UrisAreRelativeAndEncoded) {
    // Textures outside the glb's folder, with spaces, '%', '#', and UTF-8 in their names.
    Scene s;
    const std::vector<fs::path> files{dir_ / "textures dir" / "my facade #1 100%.png",
                                      dir_ / "other" / "d\xc3\xa4" "ch.jpg", dir_ / "out" / "inside.png"};
    for (size_t i = 0; i < files.size(); ++i) {
        writeFile(files[i], "x");
        s.textures.push_back({files[i].string(), 4, 4, 3, WrapMode::Wrap});
        s.triangles.push_back(tri({0, 0, double(i)}, {1, 0, double(i)}, {0, 1, double(i)}, int32_t(i), -1, 0));
    }
    // A relative texture path (relative to the current directory) works too.
    const CurrentDir in_dir(dir_);
    s.textures.push_back({"other/d\xc3\xa4" "ch.jpg", 4, 4, 3, WrapMode::Clamp});
    s.triangles.push_back(tri({0, 0, 9}, {1, 0, 9}, {0, 1, 9}, 3, -1, 0));
    const fs::path glb = dir_ / "out" / "view.glb";
    const Status st = writeDebugGlb(s, glb);
    ASSERT_TRUE(st.ok()) << st.error;

    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, s, glb);
    ASSERT_EQ(m.images.size(), 4u);
    EXPECT_EQ(m.images[0].uri, "../textures%20dir/my%20facade%20%231%20100%25.png");
    EXPECT_EQ(m.images[1].uri, "../other/d%C3%A4ch.jpg");
    EXPECT_EQ(m.images[2].uri, "inside.png");
    EXPECT_EQ(m.images[3].uri, "../other/d%C3%A4ch.jpg");
}

TEST_F(GltfDebug, UrisFollowSymlinkedFolders) {
    // The glb's folder is reached through a symlink into a deeper folder: ".."
    // must count from where the folder really is, or the URI misses the file.
    Scene s;
    const fs::path texture = dir_ / "t.png";
    writeFile(texture, "x");
    fs::create_directories(dir_ / "a" / "b");
    fs::create_directory_symlink(dir_ / "a" / "b", dir_ / "link");
    s.textures.push_back({texture.string(), 4, 4, 3, WrapMode::Wrap});
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, -1, 0));
    const fs::path glb = dir_ / "link" / "v.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, s, glb);
    ASSERT_EQ(m.images.size(), 1u);
    EXPECT_EQ(m.images[0].uri, "../../t.png");
    EXPECT_TRUE(fs::exists(dir_ / "a" / "b" / "v.glb"));
}

TEST_F(GltfDebug, UnusedTexturesAreNotWritten) {
    Scene s;
    for (int i = 0; i < 3; ++i) {
        const fs::path p = dir_ / numbered("t", i, ".png");
        writeFile(p, "x");
        s.textures.push_back({p.string(), 4, 4, 3, WrapMode::Wrap});
    }
    s.textures.push_back({"", 4, 4, 3, WrapMode::Wrap});  // no path: its triangles count as untextured
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 2, -1, 1));
    s.triangles.push_back(tri({0, 0, 1}, {1, 0, 1}, {0, 1, 1}, 3, -1, 2));
    const fs::path glb = dir_ / "u.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, s, glb);
    ASSERT_EQ(m.images.size(), 1u);
    EXPECT_EQ(m.images[0].uri, "t2.png");
}

TEST_F(GltfDebug, EmptySceneIsAValidGlbWithoutMesh) {
    Scene s;
    const fs::path glb = dir_ / "empty.glb";
    const Status st = writeDebugGlb(s, glb);
    ASSERT_TRUE(st.ok()) << st.error;
    const tinygltf::Model m = load(glb);
    expectMatchesScene(m, s, glb);
    EXPECT_TRUE(m.buffers.empty());
    EXPECT_TRUE(m.accessors.empty());

    // All triangles dropped: the same.
    s.triangles.push_back(tri({std::nan(""), 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 0));
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    expectMatchesScene(load(glb), s, glb);
}

TEST_F(GltfDebug, GlbHeaderAndChunks) {
    Scene s;
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 0));
    const fs::path glb = dir_ / "h.glb";
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    std::ifstream in(glb, std::ios::binary);
    const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    ASSERT_GE(bytes.size(), 28u);
    auto u32 = [&](size_t at) {
        uint32_t v;
        std::memcpy(&v, bytes.data() + at, 4);
        return v;
    };
    EXPECT_EQ(bytes.substr(0, 4), "glTF");
    EXPECT_EQ(u32(4), 2u);
    EXPECT_EQ(u32(8), bytes.size());
    const uint32_t json_len = u32(12);
    EXPECT_EQ(json_len % 4, 0u);
    EXPECT_EQ(bytes.substr(16, 4), "JSON");
    const size_t bin = 20 + json_len;
    ASSERT_LE(bin + 8, bytes.size());
    EXPECT_EQ(u32(bin), bytes.size() - bin - 8);
    EXPECT_EQ(bytes.substr(bin + 4, 4), std::string("BIN\0", 4));
    EXPECT_EQ(bytes.size() % 4, 0u);
}

TEST_F(GltfDebug, MissingFolderFailsWithPathAndLeavesNothing) {
    Scene s;
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 0));
    const fs::path glb = dir_ / "no_such_dir" / "x.glb";
    const Status st = writeDebugGlb(s, glb);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find(glb.string()), std::string::npos) << st.error;
    EXPECT_EQ(st.error.find('\n'), std::string::npos) << "one line";
    EXPECT_FALSE(fs::exists(dir_ / "no_such_dir"));
    EXPECT_TRUE(listDir(dir_).empty());

    const Status empty_name = writeDebugGlb(s, "");
    EXPECT_FALSE(empty_name.ok());
}

TEST_F(GltfDebug, FailedRenameLeavesNoFile) {
    // The target is an existing (non-empty) folder: the rename fails after the
    // data was written; neither the target nor the temporary may remain changed.
    Scene s;
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 0));
    const fs::path target = dir_ / "taken.glb";
    writeFile(target / "keep.txt", "x");
    const Status st = writeDebugGlb(s, target);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find(target.string()), std::string::npos) << st.error;
    EXPECT_EQ(listDir(dir_), (std::vector<std::string>{"taken.glb"}));
    EXPECT_TRUE(fs::is_directory(target));
    EXPECT_EQ(listDir(target), (std::vector<std::string>{"keep.txt"}));
}

TEST_F(GltfDebug, ReadOnlyFolderFailsCleanly) {
    if (::geteuid() == 0) GTEST_SKIP() << "root ignores directory permissions";
    Scene s;
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 0));
    const fs::path ro = dir_ / "ro";
    fs::create_directories(ro);
    fs::permissions(ro, fs::perms::owner_read | fs::perms::owner_exec);
    const Status st = writeDebugGlb(s, ro / "x.glb");
    fs::permissions(ro, fs::perms::owner_all);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find((ro / "x.glb").string()), std::string::npos) << st.error;
    EXPECT_TRUE(listDir(ro).empty());
}

TEST_F(GltfDebug, OverwritesAnExistingFileAtomically) {
    Scene s;
    s.triangles.push_back(tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, -1, -1, 0));
    const fs::path glb = dir_ / "o.glb";
    writeFile(glb, "old contents");
    ASSERT_TRUE(writeDebugGlb(s, glb).ok());
    expectMatchesScene(load(glb), s, glb);
    EXPECT_EQ(listDir(dir_), (std::vector<std::string>{"o.glb"}));
}
