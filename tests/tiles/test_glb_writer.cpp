// SPDX-License-Identifier: GPL-3.0-or-later
// encodeTileGlb / decodeTileGlb: Draco-compressed tile geometry in a GLB.
//
// Vertex correspondence: Draco's edgebreaker renumbers vertices and faces, so
// exact per-vertex checks use DracoSettings::preserve_order (Draco's sequential
// codec, which keeps both orders); the default codec is checked by matching
// every decoded triangle to a distinct input triangle within the tolerances.
#include "tiles/glb_writer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "ingest/scene.h"
#include "ingest/synth/town.h"

namespace cityatlas::tiles {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// --- Fixtures ---------------------------------------------------------------

Scene townScene(uint32_t buildings, uint64_t seed = 7) {
    synth::TownSettings settings;
    settings.buildings = buildings;
    settings.seed = seed;
    settings.texture_size_px = 64;
    // No file is written: townToScene only makes texture paths absolute.
    return synth::townToScene(synth::generateTown(settings), "/nonexistent/cityatlas_glb_town");
}

// Atlas coordinates for the test: any deterministic function of the corner
// into [0,1] that varies across the mesh.
Vec2d fakeAtlasUv(const Vec3d& p) {
    auto fract = [](double v) { return v - std::floor(v); };
    return {fract(0.0137 * p.x + 0.031 * p.z), fract(0.0291 * p.y + 0.017 * p.z)};
}

// An indexed mesh from the scene's triangles (first `max_features` buildings
// only when given), every position shifted by `offset`. Corners equal in
// position, uv and feature share a vertex, as a real tile's would.
TileMesh meshFromScene(const Scene& scene, const Vec3d& offset, uint32_t max_features = UINT32_MAX) {
    TileMesh m;
    std::map<std::tuple<double, double, double, double, double, uint32_t>, uint32_t> index_of;
    for (const Triangle& t : scene.triangles) {
        if (t.feature >= max_features) continue;
        for (int k = 0; k < 3; ++k) {
            const Vec3d& p = t.position_local[k];
            const auto key = std::make_tuple(p.x, p.y, p.z, t.uv[k].x, t.uv[k].y, t.feature);
            auto [it, inserted] = index_of.emplace(key, static_cast<uint32_t>(m.positions.size()));
            if (inserted) {
                m.positions.push_back(p + offset);
                m.uv_original.push_back(t.uv[k]);
                m.uv_atlas.push_back(fakeAtlasUv(p));
                m.feature_id.push_back(t.feature);
            }
            m.indices.push_back(it->second);
        }
    }
    return m;
}

// A flat grid of n x n vertices (more than 65535 selects 32-bit indices).
TileMesh gridMesh(int n, double spacing) {
    TileMesh m;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            m.positions.push_back({i * spacing, j * spacing, 0.01 * ((i * 7 + j * 3) % 11)});
            m.uv_atlas.push_back({double(i) / (n - 1), double(j) / (n - 1)});
        }
    for (int j = 0; j + 1 < n; ++j)
        for (int i = 0; i + 1 < n; ++i) {
            const auto v = static_cast<uint32_t>(j * n + i);
            const auto w = static_cast<uint32_t>(n);
            m.indices.insert(m.indices.end(), {v, v + 1, v + w + 1, v, v + w + 1, v + w});
        }
    return m;
}

// v rounded to float32 and back. Through a volatile: GCC 12.2 at -O2/-O3
// deletes (double)(float)x when its SLP vectorizer pairs two such conversions
// (seen here: Vec3d{double(float(p.x)), double(float(p.y)), ...} kept x and y
// unrounded).
double viaFloat(double v) {
    volatile float f = static_cast<float>(v);
    return f;
}

Box3d boundsOf(const std::vector<Vec3d>& p) {
    Box3d b;
    for (const Vec3d& v : p) b.extend(v);
    return b;
}
Vec3d centreOf(const Box3d& b) { return 0.5 * (b.min + b.max); }

// Triangles whose corners coincide once written as float32 relative to the
// centre: what encodeTileGlb drops.
size_t countDegenerate(const TileMesh& m, const Vec3d& centre) {
    size_t n = 0;
    auto f = [&](uint32_t i) {
        const Vec3d r = m.positions[i] - centre;
        return std::array<float, 3>{float(r.x), float(r.y), float(r.z)};
    };
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        const auto a = f(m.indices[t]), b = f(m.indices[t + 1]), c = f(m.indices[t + 2]);
        n += (a == b || b == c || a == c) ? 1 : 0;
    }
    return n;
}

// The worst-case position error for `bits`: half a quantization step on each
// axis (step = largest bounding-box side / (2^bits - 1), as Draco quantizes),
// plus float32 rounding (input cast, Draco's dequantization multiply and add:
// a few units in the last place of the largest relative coordinate), as a
// Euclidean length over the three axes.
double positionBound(const TileMesh& m, const Vec3d& centre, int bits) {
    const Box3d b = boundsOf(m.positions);
    const double extent = std::max({b.max.x - b.min.x, b.max.y - b.min.y, b.max.z - b.min.z});
    double largest = 0;
    for (const Vec3d& p : m.positions) {
        const Vec3d r = p - centre;
        largest = std::max({largest, std::abs(r.x), std::abs(r.y), std::abs(r.z)});
    }
    const double ulp = std::ldexp(1.0, std::ilogb(std::max(largest, 1e-30)) - 23);
    const double step = extent / (std::ldexp(1.0, bits) - 1);
    return std::sqrt(3.0) * (step / 2 + 2 * ulp);
}

// Quantization step of one uv set (largest extent over u and v).
double uvStep(const std::vector<Vec2d>& uv, int bits) {
    double lo_u = 1e300, hi_u = -1e300, lo_v = 1e300, hi_v = -1e300;
    for (const Vec2d& t : uv) {
        lo_u = std::min(lo_u, t.x), hi_u = std::max(hi_u, t.x);
        lo_v = std::min(lo_v, t.y), hi_v = std::max(hi_v, t.y);
    }
    return std::max(hi_u - lo_u, hi_v - lo_v) / (std::ldexp(1.0, bits) - 1);
}

GlbResult encodeOk(const TileMesh& m, const Vec3d& centre, const DracoSettings& s, const json& extras = {}) {
    GlbResult r;
    const Status st = encodeTileGlb(m, centre, s, &r, extras);
    EXPECT_TRUE(st.ok()) << st.error;
    return r;
}

TileMesh decodeOk(const GlbResult& r) {
    TileMesh d;
    const Status st = decodeTileGlb(r.bytes, r.centre, &d);
    EXPECT_TRUE(st.ok()) << st.error;
    return d;
}

uint32_t u32At(const std::vector<uint8_t>& b, size_t at) {
    uint32_t v = 0;
    std::memcpy(&v, b.data() + at, 4);
    return v;
}

json jsonChunk(const std::vector<uint8_t>& glb) {
    const uint32_t n = u32At(glb, 12);
    return json::parse(glb.begin() + 20, glb.begin() + 20 + n);
}

// Every decoded triangle matches a distinct input triangle (same winding, any
// starting corner): positions within `pos_tol`, uvs within `uv_tol`, feature
// ids equal. Returns the number of decoded triangles without a match.
size_t unmatchedTriangles(const TileMesh& in, const TileMesh& out, double pos_tol, double uv_tol) {
    // Input triangles hashed by the 1 m cell of their centroid; a decoded
    // centroid is within pos_tol (<< 1 m) of its input one, so searching the
    // 27 neighbouring cells finds it.
    auto centroid = [](const TileMesh& m, size_t t) {
        return (1.0 / 3) * (m.positions[m.indices[t]] + m.positions[m.indices[t + 1]] + m.positions[m.indices[t + 2]]);
    };
    auto cell = [](const Vec3d& c, int dx, int dy, int dz) {
        return std::make_tuple(int64_t(std::floor(c.x)) + dx, int64_t(std::floor(c.y)) + dy, int64_t(std::floor(c.z)) + dz);
    };
    std::map<std::tuple<int64_t, int64_t, int64_t>, std::vector<size_t>> grid;
    for (size_t t = 0; t < in.indices.size(); t += 3) grid[cell(centroid(in, t), 0, 0, 0)].push_back(t);
    std::vector<bool> used(in.indices.size() / 3, false);
    auto corner_matches = [&](uint32_t a, uint32_t b) {
        if (length(out.positions[a] - in.positions[b]) > pos_tol) return false;
        if (!in.uv_original.empty() && (std::abs(out.uv_original[a].x - in.uv_original[b].x) > uv_tol ||
                                        std::abs(out.uv_original[a].y - in.uv_original[b].y) > uv_tol))
            return false;
        if (!in.feature_id.empty() && out.feature_id[a] != in.feature_id[b]) return false;
        return true;
    };
    size_t unmatched = 0;
    for (size_t t = 0; t < out.indices.size(); t += 3) {
        const Vec3d c = centroid(out, t);
        bool found = false;
        for (int dx = -1; dx <= 1 && !found; ++dx)
            for (int dy = -1; dy <= 1 && !found; ++dy)
                for (int dz = -1; dz <= 1 && !found; ++dz) {
                    auto it = grid.find(cell(c, dx, dy, dz));
                    if (it == grid.end()) continue;
                    for (size_t s : it->second) {
                        if (used[s / 3]) continue;
                        for (int r = 0; r < 3 && !found; ++r) {
                            found = corner_matches(out.indices[t], in.indices[s + r]) &&
                                    corner_matches(out.indices[t + 1], in.indices[s + (r + 1) % 3]) &&
                                    corner_matches(out.indices[t + 2], in.indices[s + (r + 2) % 3]);
                        }
                        if (found) {
                            used[s / 3] = true;
                            break;
                        }
                    }
                }
        unmatched += found ? 0 : 1;
    }
    return unmatched;
}

// --- Round trips --------------------------------------------------------------

// Sequential codec: vertex i and triangle t of the file are input vertex i and
// triangle t (every vertex of these meshes is used), so every check is exact
// per vertex.
TEST(TileGlb, RoundTripKeepsEveryVertexWithinTheMeasuredAndTheoreticalError) {
    const Scene scene = townScene(60);
    const TileMesh in = meshFromScene(scene, {});
    ASSERT_GT(in.indices.size() / 3, 1000u);
    const Vec3d centre = centreOf(boundsOf(in.positions));
    ASSERT_EQ(countDegenerate(in, centre), 0u) << "the fixture was expected to have no degenerate triangles";

    double previous = std::numeric_limits<double>::infinity();
    for (int bits : {11, 14, 16}) {
        SCOPED_TRACE(bits);
        DracoSettings s;
        s.position_bits = bits;
        s.preserve_order = true;
        const GlbResult r = encodeOk(in, centre, s);
        const TileMesh out = decodeOk(r);
        ASSERT_EQ(out.positions.size(), in.positions.size());
        ASSERT_EQ(out.indices, in.indices);
        EXPECT_EQ(r.triangles, in.indices.size() / 3);
        EXPECT_EQ(r.vertices, in.positions.size());

        double worst = 0;
        for (size_t i = 0; i < in.positions.size(); ++i) {
            const double e = length(out.positions[i] - in.positions[i]);
            worst = std::max(worst, e);
            ASSERT_LE(e, r.max_position_error_m + 1e-12) << "vertex " << i;
        }
        // The reported number is the measured maximum, not an estimate.
        EXPECT_NEAR(worst, r.max_position_error_m, 1e-12);
        const double bound = positionBound(in, centre, bits);
        EXPECT_LE(r.max_position_error_m, bound);
        // The bits are really used: thousands of vertices on a 0.625 m plan
        // grid, rotated, hit at least a quarter of the bound somewhere.
        EXPECT_GT(r.max_position_error_m, bound / 4);
        EXPECT_LT(r.max_position_error_m, previous);
        previous = r.max_position_error_m;

        const double step0 = uvStep(in.uv_original, s.uv_bits), step1 = uvStep(in.uv_atlas, s.uv_bits);
        EXPECT_NEAR(r.uv_original_step, step0, step0 * 1e-6);
        for (size_t i = 0; i < in.positions.size(); ++i) {
            ASSERT_LE(std::abs(out.uv_original[i].x - in.uv_original[i].x), step0) << i;
            ASSERT_LE(std::abs(out.uv_original[i].y - in.uv_original[i].y), step0) << i;
            ASSERT_LE(std::abs(out.uv_atlas[i].x - in.uv_atlas[i].x), step1) << i;
            ASSERT_LE(std::abs(out.uv_atlas[i].y - in.uv_atlas[i].y), step1) << i;
        }
        EXPECT_LE(r.max_uv_original_error, step0 / 2 * (1 + 1e-3));
        EXPECT_LE(r.max_uv_atlas_error, step1 / 2 * (1 + 1e-3));
        EXPECT_GT(r.max_uv_atlas_error, 0.0);
        EXPECT_EQ(out.feature_id, in.feature_id);

        std::printf("[ sizes    ] %d bits, sequential: %zu triangles, %zu vertices, %zu B glb (Draco %zu B), "
                    "max error %.3f mm (bound %.3f mm, step %.3f mm), uv error %.2e / %.2e\n",
                    bits, r.triangles, r.vertices, r.bytes.size(), r.draco_bytes, 1e3 * r.max_position_error_m,
                    1e3 * bound, 1e3 * r.position_step_m, r.max_uv_original_error, r.max_uv_atlas_error);
    }
}

// The original uvs have their own bit count: a mesh whose original uvs span
// hundreds of repeats (the towns' paving) keeps them to the finer step while
// the atlas uvs stay at uv_bits, and the reported steps and errors say so.
TEST(TileGlb, OriginalUvsGetTheirOwnQuantization) {
    const Scene scene = townScene(12);
    const TileMesh in = meshFromScene(scene, {});
    const Vec3d centre = centreOf(boundsOf(in.positions));
    double extent = 0;
    for (const Vec2d& t : in.uv_original) extent = std::max({extent, std::abs(t.x), std::abs(t.y)});
    ASSERT_GT(extent, 50.0) << "the town should hold a texture repeated many times";
    DracoSettings coarse;
    coarse.preserve_order = true;
    DracoSettings fine = coarse;
    fine.uv_original_bits = 22;
    const GlbResult a = encodeOk(in, centre, coarse), b = encodeOk(in, centre, fine);
    const TileMesh da = decodeOk(a), db = decodeOk(b);
    const double step12 = uvStep(in.uv_original, 12), step22 = uvStep(in.uv_original, 22);
    EXPECT_NEAR(a.uv_original_step, step12, step12 * 1e-6);
    EXPECT_NEAR(b.uv_original_step, step22, step22 * 1e-6);
    EXPECT_EQ(a.uv_atlas_step, b.uv_atlas_step);
    double worst_a = 0, worst_b = 0;
    for (size_t i = 0; i < in.uv_original.size(); ++i) {
        worst_a = std::max({worst_a, std::abs(da.uv_original[i].x - in.uv_original[i].x),
                            std::abs(da.uv_original[i].y - in.uv_original[i].y)});
        worst_b = std::max({worst_b, std::abs(db.uv_original[i].x - in.uv_original[i].x),
                            std::abs(db.uv_original[i].y - in.uv_original[i].y)});
        ASSERT_EQ(da.uv_atlas[i].x, db.uv_atlas[i].x) << i;
        ASSERT_EQ(da.uv_atlas[i].y, db.uv_atlas[i].y) << i;
    }
    // 12 bits over the repeats: far more than a 64-texel texture's texel.
    EXPECT_GT(worst_a, 1.0 / 64);
    EXPECT_NEAR(worst_a, a.max_uv_original_error, 1e-12);
    // 22 bits: a half step plus float32 rounding of values in the hundreds.
    EXPECT_LE(worst_b, step22 / 2 + extent * 1e-7);
    EXPECT_NEAR(worst_b, b.max_uv_original_error, 1e-12);
}

// Edgebreaker (the default) renumbers vertices and faces: every decoded
// triangle must still be one of the input triangles, with its winding.
TEST(TileGlb, EdgebreakerRoundTripMatchesEveryTriangle) {
    const Scene scene = townScene(30);
    const TileMesh in = meshFromScene(scene, {});
    const Vec3d centre = centreOf(boundsOf(in.positions));
    for (int bits : {11, 14, 16}) {
        SCOPED_TRACE(bits);
        DracoSettings s;
        s.position_bits = bits;
        const GlbResult r = encodeOk(in, centre, s);
        const TileMesh out = decodeOk(r);
        EXPECT_EQ(r.triangles, in.indices.size() / 3);
        EXPECT_EQ(out.indices.size(), in.indices.size());
        EXPECT_EQ(r.vertices, out.positions.size());
        EXPECT_LE(r.max_position_error_m, positionBound(in, centre, bits));
        const double uv_tol = std::max(uvStep(in.uv_original, s.uv_bits), 1e-12);
        EXPECT_EQ(unmatchedTriangles(in, out, r.max_position_error_m + 1e-12, uv_tol), 0u);
        for (size_t i = 0; i < out.uv_atlas.size(); ++i) {
            ASSERT_GE(out.uv_atlas[i].x, -1e-6);
            ASSERT_LE(out.uv_atlas[i].x, 1 + 1e-6);
        }

        DracoSettings seq = s;
        seq.preserve_order = true;
        const GlbResult rs = encodeOk(in, centre, seq);
        // Same quantization, so the same measured error; a smaller file.
        EXPECT_EQ(r.max_position_error_m, rs.max_position_error_m);
        EXPECT_LT(r.bytes.size(), rs.bytes.size());
        std::printf("[ sizes    ] %d bits, edgebreaker: %zu triangles, %zu vertices, %zu B glb (sequential %zu B; "
                    "%zu B as plain float32 + uint32 indices)\n",
                    bits, r.triangles, r.vertices, r.bytes.size(), rs.bytes.size(),
                    in.positions.size() * (12 + 8 + 8 + 4) + in.indices.size() * 4);
    }
    // The matcher can fail: a tolerance below the real error leaves triangles unmatched.
    DracoSettings coarse;
    coarse.position_bits = 8;
    const GlbResult r = encodeOk(in, centre, coarse);
    EXPECT_GT(unmatchedTriangles(in, decodeOk(r), 1e-3, 1.0), 0u);
}

TEST(TileGlb, FeatureIdsUpTo2Pow24AreExact) {
    const Scene scene = townScene(12);
    TileMesh in = meshFromScene(scene, {});
    // Spread the ids over the whole exact range, both ends included: the
    // large odd ones are where a quantized or float16 path would round.
    const uint32_t top = (1u << 24) - 1;
    for (uint32_t& f : in.feature_id) f = f == 0 ? top : f == 1 ? kMaxTileFeatureId : top - 2 * f * 99991u % top;
    const Vec3d centre = centreOf(boundsOf(in.positions));
    for (bool ordered : {true, false}) {
        DracoSettings s;
        s.preserve_order = ordered;
        const GlbResult r = encodeOk(in, centre, s);
        const TileMesh out = decodeOk(r);
        if (ordered) {
            EXPECT_EQ(out.feature_id, in.feature_id);
        } else {
            // Edgebreaker may split vertices: compare the per-corner ids.
            std::multiset<uint32_t> want, got;
            for (uint32_t i : in.indices) want.insert(in.feature_id[i]);
            for (uint32_t i : out.indices) got.insert(out.feature_id[i]);
            EXPECT_EQ(got, want);
        }
        const json j = jsonChunk(r.bytes);
        const json& acc = j["accessors"][j["meshes"][0]["primitives"][0]["attributes"]["_FEATURE_ID_0"].get<int>()];
        EXPECT_EQ(acc["max"][0].get<double>(), double(kMaxTileFeatureId));
    }
    // One above: not exact in float32, refused with a reason.
    in.feature_id[5] = kMaxTileFeatureId + 1;
    GlbResult r;
    const Status st = encodeTileGlb(in, centre, {}, &r);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find("2^24"), std::string::npos) << st.error;
    EXPECT_TRUE(r.bytes.empty());
}

// --- Precision far from the origin ---------------------------------------------

TEST(TileGlb, MillimetresAtNorthing1e7AndEcefMagnitudesOnlyWithTheCentre) {
    const Scene scene = townScene(12);
    // Building 0 alone stands on one 30 m lot: its bounding box is the
    // "building-block sized" mesh (14 bits -> 1.8 mm step). Buildings 0..5
    // fill a 90 m x 60 m city block (5.5 mm step at 14 bits).
    // The synthetic town is exact in binary (0.625 m grid, 1/8 m heights), and
    // so would float32 be at these magnitudes; surveyed coordinates are
    // millimetre decimals, hence the decimal offsets.
    const std::vector<std::pair<const char*, Vec3d>> places{
        {"northing 9.9e6", {690123.457, 9900000.321, 35.789}},
        {"ECEF 6.4e6 on every axis", {6400000.123, 6400000.457, 6400000.789}}};
    for (const auto& [where, offset] : places) {
        SCOPED_TRACE(where);
        for (uint32_t buildings : {1u, 6u}) {
            SCOPED_TRACE(buildings);
            const TileMesh in = meshFromScene(scene, offset, buildings);
            const Box3d box = boundsOf(in.positions);
            const Vec3d centre = centreOf(box);
            const double extent = std::max({box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z});
            for (int bits : {14, 16}) {
                DracoSettings s;
                s.position_bits = bits;
                s.preserve_order = true;
                const GlbResult r = encodeOk(in, centre, s);
                const TileMesh out = decodeOk(r);
                ASSERT_EQ(out.positions.size(), in.positions.size());
                double worst = 0;
                for (size_t i = 0; i < in.positions.size(); ++i)
                    worst = std::max(worst, length(out.positions[i] - in.positions[i]));
                EXPECT_NEAR(worst, r.max_position_error_m, 1e-12);
                EXPECT_LE(worst, positionBound(in, centre, bits));
                // The guarantee: 2 mm at 14 bits up to a 37 m extent; the
                // 90 m block needs 16 bits for it.
                if (extent <= 37.8 || bits == 16) {
                    EXPECT_LE(worst, 0.002) << "extent " << extent << " m";
                    // Edgebreaker (the default codec) too: every triangle within 2 mm.
                    s.preserve_order = false;
                    const TileMesh eb = decodeOk(encodeOk(in, centre, s));
                    EXPECT_EQ(unmatchedTriangles(in, eb, 0.002, uvStep(in.uv_original, s.uv_bits)), 0u);
                }
                std::printf("[ extreme  ] %s, %u building(s), extent %.1f m, %d bits: max error %.3f mm\n", where,
                            buildings, extent, bits, 1e3 * worst);
            }
            if (buildings == 1) {
                ASSERT_LE(extent, 37.8);
            }

            // Without the centre the positions go into float32 as they are:
            // 0.5 m spacing at 6.4e6, 1 m at 9.9e6.
            double float_only = 0;
            for (const Vec3d& p : in.positions)
                float_only = std::max(float_only, length(Vec3d{viaFloat(p.x), viaFloat(p.y), viaFloat(p.z)} - p));
            EXPECT_GT(float_only, 0.25);
            DracoSettings s;
            s.preserve_order = true;
            const GlbResult r0 = encodeOk(in, Vec3d{}, s);
            EXPECT_GT(r0.max_position_error_m, 0.25);
            const TileMesh out0 = decodeOk(r0);
            double worst0 = 0;
            for (size_t i = 0; i < in.positions.size(); ++i)
                worst0 = std::max(worst0, length(out0.positions[i] - in.positions[i]));
            EXPECT_GT(worst0, 0.25);
            std::printf("[ extreme  ] %s, %u building(s), centre 0: float32 alone %.3f m, file %.3f m\n", where,
                        buildings, float_only, worst0);
        }
    }
}

// --- The glTF JSON ---------------------------------------------------------------

void expectWiring(const GlbResult& r, const json& expected_extras) {
    const std::vector<uint8_t>& b = r.bytes;
    ASSERT_GE(b.size(), 28u);
    EXPECT_EQ(u32At(b, 0), 0x46546C67u);
    EXPECT_EQ(u32At(b, 4), 2u);
    EXPECT_EQ(u32At(b, 8), b.size());
    const uint32_t json_len = u32At(b, 12);
    EXPECT_EQ(u32At(b, 16), 0x4E4F534Au);
    EXPECT_EQ(json_len % 4, 0u);
    const size_t bin_at = 20 + json_len;
    ASSERT_LE(bin_at + 8, b.size());
    const uint32_t bin_len = u32At(b, bin_at);
    EXPECT_EQ(u32At(b, bin_at + 4), 0x004E4942u);
    EXPECT_EQ(bin_len % 4, 0u);
    EXPECT_EQ(bin_at + 8 + bin_len, b.size());

    const json j = jsonChunk(b);
    EXPECT_EQ(j["asset"]["version"], "2.0");
    EXPECT_EQ(j["asset"]["generator"], "cityatlas");
    if (expected_extras.is_null()) {
        EXPECT_FALSE(j["asset"].contains("extras"));
    } else {
        EXPECT_EQ(j["asset"]["extras"], expected_extras);
    }
    EXPECT_EQ(j["extensionsUsed"], json::array({"KHR_draco_mesh_compression"}));
    EXPECT_EQ(j["extensionsRequired"], json::array({"KHR_draco_mesh_compression"}));
    EXPECT_EQ(j["scene"], 0);
    EXPECT_EQ(j["scenes"], json::parse(R"([{"nodes":[0]}])"));
    // The centre is the client's business in double: no node translation.
    EXPECT_EQ(j["nodes"], json::parse(R"([{"mesh":0}])"));
    ASSERT_EQ(j["meshes"].size(), 1u);
    ASSERT_EQ(j["meshes"][0]["primitives"].size(), 1u);
    const json& prim = j["meshes"][0]["primitives"][0];
    EXPECT_EQ(prim["mode"], 4);
    const json& ext = prim["extensions"]["KHR_draco_mesh_compression"];
    ASSERT_TRUE(ext.is_object());
    // The extension's attributes are exactly the primitive's.
    ASSERT_EQ(ext["attributes"].size(), prim["attributes"].size());
    for (const auto& [name, id] : ext["attributes"].items()) {
        EXPECT_TRUE(prim["attributes"].contains(name)) << name;
        EXPECT_TRUE(id.is_number_unsigned()) << name;
    }
    const json& view = j["bufferViews"][ext["bufferView"].get<int>()];
    EXPECT_EQ(view["buffer"], 0);
    EXPECT_EQ(view["byteOffset"], 0);
    EXPECT_EQ(view["byteLength"], r.draco_bytes);
    EXPECT_FALSE(view.contains("byteStride"));
    ASSERT_EQ(j["buffers"].size(), 1u);
    EXPECT_EQ(j["buffers"][0]["byteLength"], r.draco_bytes);
    EXPECT_FALSE(j["buffers"][0].contains("uri"));
    EXPECT_LE(r.draco_bytes, bin_len);
    EXPECT_GT(r.draco_bytes + 4, bin_len);
    // The Draco blob starts with Draco's own magic.
    EXPECT_EQ(std::string(b.begin() + long(bin_at) + 8, b.begin() + long(bin_at) + 13), "DRACO");

    const std::map<std::string, std::string> types{
        {"POSITION", "VEC3"}, {"TEXCOORD_0", "VEC2"}, {"TEXCOORD_1", "VEC2"}, {"_FEATURE_ID_0", "SCALAR"}};
    for (const auto& [name, index] : prim["attributes"].items()) {
        SCOPED_TRACE(name);
        ASSERT_TRUE(types.contains(name));
        const json& acc = j["accessors"][index.get<int>()];
        EXPECT_FALSE(acc.contains("bufferView"));  // the extension supplies the data
        EXPECT_EQ(acc["componentType"], 5126);
        EXPECT_EQ(acc["type"], types.at(name));
        EXPECT_EQ(acc["count"], r.vertices);
        EXPECT_TRUE(acc["min"].is_array() && acc["max"].is_array());
    }
    const json& idx = j["accessors"][prim["indices"].get<int>()];
    EXPECT_FALSE(idx.contains("bufferView"));
    EXPECT_EQ(idx["type"], "SCALAR");
    EXPECT_EQ(idx["count"], 3 * r.triangles);
    EXPECT_EQ(idx["componentType"], r.vertices <= 65535 ? 5123 : 5125);

    // POSITION min/max are the decoded extremes exactly (the file's float32
    // values, relative to the centre).
    const TileMesh out = decodeOk(r);
    std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
    for (const Vec3d& p : out.positions) {
        const Vec3d q = p - r.centre;  // exact: p was float + centre
        const std::array<double, 3> a{q.x, q.y, q.z};
        for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], a[k]), hi[k] = std::max(hi[k], a[k]);
    }
    const json& pos = j["accessors"][prim["attributes"]["POSITION"].get<int>()];
    for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(pos["min"][k].get<double>(), lo[k]) << k;
        EXPECT_EQ(pos["max"][k].get<double>(), hi[k]) << k;
        EXPECT_EQ(viaFloat(lo[k]), lo[k]);  // a float32 value, as the spec requires
    }
}

// A node 40 km across (the root of a city) cannot be written to 2 mm: float32
// spaces its far corners 2 mm apart. usefulPositionBits stops where more bits
// buy less than one float32 spacing, and asks for every bit a block needs.
TEST(TileGlb, PositionBitsStopWhereFloat32StopsResolving) {
    TileMesh city = gridMesh(64, 40000.0 / 63);
    for (Vec3d& p : city.positions) p = p + Vec3d{0.3183, 0.2719, 0.1414};  // not binary fractions
    const Box3d box = boundsOf(city.positions);
    const Vec3d centre = centreOf(box);
    const int useful = usefulPositionBits(city, centre);
    EXPECT_GE(useful, 20);
    EXPECT_LE(useful, 26);
    DracoSettings s;
    s.preserve_order = true;
    s.position_bits = useful;
    const GlbResult at_useful = encodeOk(city, centre, s);
    s.position_bits = 30;
    const GlbResult at_30 = encodeOk(city, centre, s);
    const float far = 20000.0f;
    const double spacing = static_cast<double>(std::nextafter(far, 1e30f) - far);
    EXPECT_LE(at_useful.max_position_error_m, at_30.max_position_error_m + spacing)
        << "the bits above " << useful << " would have bought more than a float32 spacing";
    // One bit fewer would cost more than that: the cap is not lower than it must be.
    s.position_bits = useful - 2;
    EXPECT_GT(encodeOk(city, centre, s).max_position_error_m, at_30.max_position_error_m + 0.5 * spacing);

    // A 60 m block keeps the bits a 0.1 mm target asks for (24 at its extent).
    TileMesh block = gridMesh(16, 4.0);
    const Vec3d block_centre = centreOf(boundsOf(block.positions));
    EXPECT_GE(usefulPositionBits(block, block_centre), 24);
}

TEST(TileGlb, JsonChunkCarriesTheRequiredGltfFieldsAndTheExtensionWiring) {
    const Scene scene = townScene(12);
    const TileMesh in = meshFromScene(scene, {690000, 5336000, 0});
    const Vec3d centre = centreOf(boundsOf(in.positions));
    const json extras = {{"centre", {centre.x, centre.y, centre.z}}, {"tile", "0/0/0"}};
    {
        SCOPED_TRACE("town with extras");
        expectWiring(encodeOk(in, centre, {}, extras), extras);
    }
    {
        SCOPED_TRACE("positions only, no extras");
        TileMesh bare = in;
        bare.uv_original.clear();
        bare.uv_atlas.clear();
        bare.feature_id.clear();
        const GlbResult r = encodeOk(bare, centre, {});
        expectWiring(r, nullptr);
        const json j = jsonChunk(r.bytes);
        EXPECT_EQ(j["meshes"][0]["primitives"][0]["attributes"].size(), 1u);
        const TileMesh out = decodeOk(r);
        EXPECT_TRUE(out.uv_original.empty() && out.uv_atlas.empty() && out.feature_id.empty());
    }
    {
        // glTF forbids TEXCOORD_1 without TEXCOORD_0: a lone atlas set is
        // TEXCOORD_0, and the primitive's extras say so.
        SCOPED_TRACE("atlas uvs only");
        TileMesh atlas_only = in;
        atlas_only.uv_original.clear();
        const GlbResult r = encodeOk(atlas_only, centre, {});
        expectWiring(r, nullptr);
        const json prim = jsonChunk(r.bytes)["meshes"][0]["primitives"][0];
        EXPECT_TRUE(prim["attributes"].contains("TEXCOORD_0"));
        EXPECT_FALSE(prim["attributes"].contains("TEXCOORD_1"));
        EXPECT_EQ(prim["extras"]["cityatlas_texcoords"], json::array({"atlas"}));
        const TileMesh out = decodeOk(r);
        EXPECT_TRUE(out.uv_original.empty());
        EXPECT_EQ(out.uv_atlas.size(), out.positions.size());
        const json both = jsonChunk(encodeOk(in, centre, {}).bytes)["meshes"][0]["primitives"][0];
        EXPECT_EQ(both["extras"]["cityatlas_texcoords"], json::array({"original", "atlas"}));
    }
    {
        SCOPED_TRACE("more than 65535 vertices: 32-bit indices");
        const TileMesh grid = gridMesh(260, 0.5);
        const GlbResult r = encodeOk(grid, centreOf(boundsOf(grid.positions)), {});
        EXPECT_GT(r.vertices, 65535u);
        expectWiring(r, nullptr);
    }
}

TEST(TileGlb, EncodingIsDeterministic) {
    const TileMesh in = meshFromScene(townScene(12), {});
    const Vec3d centre = centreOf(boundsOf(in.positions));
    const GlbResult a = encodeOk(in, centre, {}), b = encodeOk(in, centre, {});
    EXPECT_EQ(a.bytes, b.bytes);
    EXPECT_EQ(a.max_position_error_m, b.max_position_error_m);
}

// --- Bad input ---------------------------------------------------------------

TEST(TileGlb, RefusesBadInputWithAReason) {
    const TileMesh good = meshFromScene(townScene(2), {});
    const Vec3d centre = centreOf(boundsOf(good.positions));
    auto refuse = [&](const TileMesh& m, const Vec3d& c, const DracoSettings& s, const char* why) {
        GlbResult r;
        r.triangles = 12345;  // must stay untouched
        const Status st = encodeTileGlb(m, c, s, &r);
        EXPECT_FALSE(st.ok()) << why;
        EXPECT_NE(st.error.find(why), std::string::npos) << st.error;
        EXPECT_EQ(r.triangles, 12345u);
    };
    TileMesh m = good;
    m.indices.push_back(0);
    refuse(m, centre, {}, "multiple of 3");
    m = good;
    m.indices[7] = static_cast<uint32_t>(m.positions.size());
    refuse(m, centre, {}, "out of range");
    m = good;
    m.uv_atlas.pop_back();
    refuse(m, centre, {}, "uv_atlas");
    m = good;
    m.positions[3].y = std::numeric_limits<double>::quiet_NaN();
    refuse(m, centre, {}, "not finite");
    m = good;
    m.positions[3].x = 1e39;  // beyond float32 relative to the centre
    refuse(m, centre, {}, "float32");
    refuse(good, {0, std::numeric_limits<double>::infinity(), 0}, {}, "centre");
    m = good;
    m.indices.clear();
    refuse(m, centre, {}, "no triangles");
    m = good;
    m.indices = {0, 0, 1};  // degenerate only
    refuse(m, centre, {}, "degenerate");
    DracoSettings s;
    s.position_bits = 0;
    refuse(good, centre, s, "position_bits");
    s = {};
    s.uv_bits = 31;
    refuse(good, centre, s, "uv_bits");
    s = {};
    s.speed = 11;
    refuse(good, centre, s, "speed");
}

TEST(TileGlb, DropsDegenerateTrianglesAndCountsThem) {
    TileMesh m = meshFromScene(townScene(2), {});
    const size_t before = m.indices.size() / 3;
    m.indices.insert(m.indices.end(), {m.indices[0], m.indices[0], m.indices[1]});
    const GlbResult r = encodeOk(m, centreOf(boundsOf(m.positions)), {});
    EXPECT_EQ(r.degenerate_triangles_dropped, 1u);
    EXPECT_EQ(r.triangles, before);
}

// --- Robustness of the reader --------------------------------------------------

void expectErrorOrValidMesh(const std::vector<uint8_t>& bytes, const char* what, size_t where) {
    TileMesh out;
    const Status st = decodeTileGlb(bytes, {}, &out);
    if (!st.ok()) {
        EXPECT_FALSE(st.error.empty());
        EXPECT_EQ(st.error.find('\n'), std::string::npos) << st.error;
        return;
    }
    // Accepted: then it must be a usable mesh.
    EXPECT_EQ(out.indices.size() % 3, 0u) << what << " " << where;
    for (uint32_t i : out.indices) ASSERT_LT(i, out.positions.size()) << what << " " << where;
    for (const auto* v : {&out.uv_original, &out.uv_atlas})
        EXPECT_TRUE(v->empty() || v->size() == out.positions.size()) << what << " " << where;
    EXPECT_TRUE(out.feature_id.empty() || out.feature_id.size() == out.positions.size()) << what << " " << where;
    for (const Vec3d& p : out.positions) ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
}

TEST(TileGlb, ReaderSurvivesTruncationsBitFlipsAndGarbage) {
    const TileMesh in = meshFromScene(townScene(3), {});
    const GlbResult r = encodeOk(in, centreOf(boundsOf(in.positions)), {});
    const std::vector<uint8_t>& good = r.bytes;
    const size_t bin_at = 20 + u32At(good, 12) + 8;  // first byte of the Draco blob

    // Every truncation is an error that says so (about 300 lengths, every one
    // inside the headers and the first bytes of the blob).
    const size_t stride = std::max<size_t>(1, good.size() / 250);
    size_t truncations = 0;
    for (size_t n = 0; n < good.size(); n += (n < 24 || (n >= bin_at && n < bin_at + 40)) ? 1 : stride) {
        const std::vector<uint8_t> cut(good.begin(), good.begin() + long(n));
        TileMesh out;
        const Status st = decodeTileGlb(cut, {}, &out);
        ASSERT_FALSE(st.ok()) << "truncated to " << n;
        EXPECT_NE(st.error.find("truncated"), std::string::npos) << n << ": " << st.error;
        ++truncations;
    }
    EXPECT_GT(truncations, 250u);

    // Random single and multiple bit flips, fixed seed: anywhere, and in the
    // Draco blob in particular (the JSON rejects most damage earlier).
    std::mt19937_64 rng(20261122);
    int accepted = 0, rejected = 0;
    for (int i = 0; i < 600; ++i) {
        std::vector<uint8_t> bad = good;
        const size_t lo = i < 200 ? 0 : bin_at, span = bad.size() - lo;
        const int flips = 1 + int(rng() % 4);
        size_t first = 0;
        for (int f = 0; f < flips; ++f) {
            const size_t at = lo + rng() % span;
            first = f == 0 ? at : first;
            bad[at] ^= uint8_t(1u << (rng() % 8));
        }
        expectErrorOrValidMesh(bad, "bit flip at", first);
        TileMesh out;
        (decodeTileGlb(bad, {}, &out).ok() ? accepted : rejected) += 1;
    }
    std::printf("[ fuzz     ] %zu truncations rejected; bit flips: %d rejected, %d decoded\n", truncations, rejected,
                accepted);
    EXPECT_GT(rejected, 0);

    // Runs of random bytes over the blob and over the JSON.
    for (int i = 0; i < 100; ++i) {
        std::vector<uint8_t> bad = good;
        const size_t at = (i % 2 == 0 ? bin_at : 20) + rng() % 64, n = 1 + rng() % 32;
        for (size_t k = at; k < std::min(bad.size(), at + n); ++k) bad[k] = uint8_t(rng());
        expectErrorOrValidMesh(bad, "garbage run at", at);
    }

    // Specific damage, each with its own message.
    auto reason = [](const std::vector<uint8_t>& bytes) {
        TileMesh out;
        return decodeTileGlb(bytes, {}, &out).error;
    };
    std::vector<uint8_t> bad = good;
    bad[0] = 'x';
    EXPECT_NE(reason(bad).find("magic"), std::string::npos) << reason(bad);
    bad = good;
    bad.push_back(0);
    EXPECT_NE(reason(bad).find("after"), std::string::npos) << reason(bad);
    // The extension renamed (same length, so the framing stays valid).
    std::string text(good.begin() + 20, good.begin() + 20 + long(u32At(good, 12)));
    for (size_t at = text.find("KHR_draco"); at != std::string::npos; at = text.find("KHR_draco", at + 1)) text[at] = 'X';
    bad = good;
    std::copy(text.begin(), text.end(), bad.begin() + 20);
    EXPECT_NE(reason(bad).find("XHR_draco_mesh_compression"), std::string::npos) << reason(bad);
    // Only the primitive's extension removed (required list kept honest).
    json j = jsonChunk(good);
    j["meshes"][0]["primitives"][0].erase("extensions");
    std::string t2 = j.dump();
    t2.append((4 - t2.size() % 4) % 4, ' ');
    bad.assign(good.begin(), good.begin() + 12);
    const uint32_t jl = uint32_t(t2.size());
    bad.insert(bad.end(), {uint8_t(jl), uint8_t(jl >> 8), uint8_t(jl >> 16), uint8_t(jl >> 24), 'J', 'S', 'O', 'N'});
    bad.insert(bad.end(), t2.begin(), t2.end());
    bad.insert(bad.end(), good.begin() + 20 + long(u32At(good, 12)), good.end());
    const uint32_t total = uint32_t(bad.size());
    std::memcpy(bad.data() + 8, &total, 4);
    EXPECT_NE(reason(bad).find("no KHR_draco_mesh_compression"), std::string::npos) << reason(bad);
    EXPECT_NE(reason(std::vector<uint8_t>(5000, 0xAB)).find("magic"), std::string::npos);
    EXPECT_NE(reason({}).find("truncated"), std::string::npos);
}

// Found with fuzz_glb: an extensionsRequired entry nested 20000 deep was
// dumped into the message, and json::dump recurses once per level (a stack
// overflow in the client's decoder from 40 kB of JSON).
TEST(TileGlb, DeeplyNestedRequiredExtensionIsAnErrorNotAStackOverflow) {
    const size_t depth = 20000;
    std::string text = R"({"asset":{"version":"2.0"},"extensionsRequired":[)" + std::string(depth, '[') +
                       std::string(depth, ']') + "]}";
    text.append((4 - text.size() % 4) % 4, ' ');
    std::vector<uint8_t> bytes;
    auto put = [&](uint32_t v) {
        for (int i = 0; i < 4; ++i) bytes.push_back(uint8_t(v >> (8 * i)));
    };
    put(0x46546C67);  // "glTF"
    put(2);
    put(uint32_t(12 + 8 + text.size()));
    put(uint32_t(text.size()));
    put(0x4E4F534A);  // "JSON"
    bytes.insert(bytes.end(), text.begin(), text.end());
    TileMesh out;
    const Status st = decodeTileGlb(bytes, {}, &out);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error.find("requires extension (not a string)"), std::string::npos) << st.error;
    EXPECT_LT(st.error.size(), 200u) << "one short line";
}

// --- Files for the Khronos validator -------------------------------------------

// Writes sample GLBs into $CITYATLAS_GLB_OUT (tests/cli/tiles_glb_valid.sh runs
// the Khronos validator on them); without it, into a temporary folder that is
// read back and removed, so the test checks the files either way.
TEST(TileGlb, WritesSampleFilesForTheValidator) {
    const char* env = std::getenv("CITYATLAS_GLB_OUT");
    const fs::path dir = env != nullptr && *env != '\0' ? fs::path(env) : fs::path(testing::TempDir()) / "cityatlas_tile_glbs";
    fs::create_directories(dir);
    const Scene scene = townScene(12);
    std::vector<std::pair<std::string, GlbResult>> samples;
    {
        const TileMesh m = meshFromScene(scene, {690000, 5336000, 0});
        const Vec3d c = centreOf(boundsOf(m.positions));
        samples.emplace_back("town_all_attributes.glb", encodeOk(m, c, {}, {{"centre", {c.x, c.y, c.z}}}));
        DracoSettings s;
        s.preserve_order = true;
        s.position_bits = 16;
        samples.emplace_back("town_sequential_16bit.glb", encodeOk(m, c, s));
    }
    {
        TileMesh m = meshFromScene(scene, {6.4e6, 6.4e6, 6.4e6}, 1);
        m.uv_original.clear();
        m.feature_id.clear();
        const Vec3d c = centreOf(boundsOf(m.positions));
        samples.emplace_back("ecef_positions_atlas_uv.glb", encodeOk(m, c, {}, {{"centre", {c.x, c.y, c.z}}}));
    }
    {
        const TileMesh g = gridMesh(260, 0.5);
        samples.emplace_back("grid_32bit_indices.glb", encodeOk(g, centreOf(boundsOf(g.positions)), {}));
    }
    for (const auto& [name, r] : samples) {
        const fs::path p = dir / name;
        std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(r.bytes.data()), long(r.bytes.size()));
        std::ifstream f(p, std::ios::binary);
        const std::vector<uint8_t> back((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
        ASSERT_EQ(back, r.bytes) << p;
        TileMesh out;
        const Status st = decodeTileGlb(back, r.centre, &out);
        EXPECT_TRUE(st.ok()) << p << ": " << st.error;
    }
    if (env == nullptr || *env == '\0') fs::remove_all(dir);
}

}  // namespace
}  // namespace cityatlas::tiles
