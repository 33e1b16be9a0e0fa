// SPDX-License-Identifier: GPL-3.0-or-later
// simplifyMesh / weldTriangles: inner-node geometry reduced under a measured
// geometric error bound.
//
// Every error the library reports is checked against a brute-force distance
// written here (projection onto the triangle's plane with an inside test, else
// the nearest edge: a different construction from the library's Voronoi-region
// walk over a grid), over every input vertex and every output sample, so a
// wrong grid search or a wrong closest-point routine in the library shows up
// as a mismatch rather than agreeing with itself.
#include "tiles/simplify.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iterator>
#include <limits>
#include <map>
#include <set>
#include <tuple>
#include <vector>

#include <tbb/task_arena.h>

#include "ingest/scene.h"
#include "ingest/synth/town.h"

namespace cityatlas::tiles {
namespace {

// --- Independent reference measure -------------------------------------------

double segDist(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
    const Vec3d ab = b - a;
    const double l2 = dot(ab, ab);
    double t = l2 > 0 ? dot(p - a, ab) / l2 : 0.0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    const Vec3d d = p - (a + t * ab);
    return std::sqrt(dot(d, d));
}

double bruteTriDist(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
    const Vec3d n = cross(b - a, c - a);
    const double n2 = dot(n, n);
    const double edges = std::min({segDist(p, a, b), segDist(p, b, c), segDist(p, c, a)});
    if (!(n2 > 0)) return edges;
    const double h = dot(p - a, n) / n2;
    const Vec3d q = p - h * n;  // projection onto the plane
    const bool inside = dot(cross(b - a, q - a), n) >= 0 && dot(cross(c - b, q - b), n) >= 0 &&
                        dot(cross(a - c, q - c), n) >= 0;
    return inside ? std::abs(h) * std::sqrt(n2) : edges;
}

double bruteSurfaceDist(const Vec3d& p, const std::vector<Vec3d>& pos, const std::vector<uint32_t>& idx) {
    double best = std::numeric_limits<double>::infinity();
    for (size_t t = 0; t < idx.size(); t += 3)
        best = std::min(best, bruteTriDist(p, pos[idx[t]], pos[idx[t + 1]], pos[idx[t + 2]]));
    return best;
}

// The error as simplify.h defines it: input vertices to the output surface,
// and output vertices, edge midpoints and centroids to the input surface.
double bruteError(const SimplifyInput& in, const std::vector<uint32_t>& out) {
    double worst = 0;
    std::set<uint32_t> used(in.indices.begin(), in.indices.end());
    for (uint32_t v : used) worst = std::max(worst, bruteSurfaceDist(in.positions[v], in.positions, out));
    for (size_t t = 0; t < out.size(); t += 3) {
        const Vec3d& a = in.positions[out[t]];
        const Vec3d& b = in.positions[out[t + 1]];
        const Vec3d& c = in.positions[out[t + 2]];
        for (const Vec3d& s : {a, b, c, 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a), (1.0 / 3.0) * (a + b + c)})
            worst = std::max(worst, bruteSurfaceDist(s, in.positions, in.indices));
    }
    return worst;
}

// --- Fixtures ------------------------------------------------------------------

Scene townScene(uint32_t buildings, uint64_t seed = 7) {
    synth::TownSettings settings;
    settings.buildings = buildings;
    settings.seed = seed;
    settings.lod = 2;
    settings.texture_size_px = 64;
    // No file is written: townToScene only makes texture paths absolute.
    return synth::townToScene(synth::generateTown(settings), "/nonexistent/cityatlas_simplify_town");
}

// 60 LOD2 buildings (ten blocks): every footprint shape and roof type, small
// enough for the brute-force check to stay well under a second per call.
const Scene& town() {
    static const Scene scene = townScene(60);
    return scene;
}

// Smallest side of the smallest building's bounding box.
double smallestBuildingSize(const Scene& scene) {
    std::vector<Box3d> boxes(scene.features.size());
    for (const Triangle& t : scene.triangles)
        for (const Vec3d& p : t.position_local) boxes[t.feature].extend(p);
    double smallest = std::numeric_limits<double>::infinity();
    for (const Box3d& b : boxes)
        if (!b.empty())
            smallest = std::min({smallest, b.max.x - b.min.x, b.max.y - b.min.y, b.max.z - b.min.z});
    return smallest;
}

std::set<uint32_t> featuresOf(const SimplifyInput& in, const std::vector<uint32_t>& idx) {
    std::set<uint32_t> f;
    for (uint32_t i : idx) f.insert(in.feature_id[i]);
    return f;
}

// A flat n x n grid of squares, 2 triangles each, side `size` metres, as a
// triangle soup (every triangle with its own corners) at `origin`.
std::vector<Triangle> flatGrid(int n, double size, const Vec3d& origin) {
    std::vector<Triangle> tris;
    const double step = size / n;
    auto at = [&](int i, int j) { return origin + Vec3d{i * step, j * step, 0}; };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            Triangle a, b;
            a.position_local = {at(i, j), at(i + 1, j), at(i + 1, j + 1)};
            b.position_local = {at(i, j), at(i + 1, j + 1), at(i, j + 1)};
            tris.push_back(a);
            tris.push_back(b);
        }
    return tris;
}

void expectValidIndices(const SimplifyInput& in, const SimplifyResult& r) {
    ASSERT_EQ(r.indices.size() % 3, 0u);
    EXPECT_EQ(r.triangles_out, r.indices.size() / 3);
    EXPECT_EQ(r.triangles_in, in.indices.size() / 3);
    for (size_t t = 0; t < r.indices.size(); t += 3) {
        for (int k = 0; k < 3; ++k) ASSERT_LT(r.indices[t + k], in.positions.size());
        // meshopt never emits a triangle with a repeated vertex.
        EXPECT_NE(r.indices[t], r.indices[t + 1]);
        EXPECT_NE(r.indices[t + 1], r.indices[t + 2]);
        EXPECT_NE(r.indices[t + 2], r.indices[t]);
    }
}

// --- Tests -------------------------------------------------------------------

TEST(Simplify, WeldTrianglesSharesPositionsAndKeepsTheFirstFeatureId) {
    Triangle a, b;
    a.position_local = {Vec3d{0, 0, 0}, Vec3d{1, 0, 0}, Vec3d{0, 1, 0}};
    a.feature = 4;
    // Shares the edge (1,0,0)-(0,1,0); -0.0 equals +0.0 and must weld with it.
    b.position_local = {Vec3d{1, 0, -0.0}, Vec3d{1, 1, 0}, Vec3d{0, 1, 0}};
    b.feature = 9;
    const SimplifyInput in = weldTriangles({a, b});
    ASSERT_EQ(in.positions.size(), 4u);
    EXPECT_EQ(in.indices, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2}));
    EXPECT_EQ(in.feature_id, (std::vector<uint32_t>{4, 4, 4, 9}));
    EXPECT_EQ(in.positions[3], (Vec3d{1, 1, 0}));
}

TEST(Simplify, TownErrorStaysWithinEachBoundAndTrianglesDropAsTheBoundGrows) {
    const Scene& scene = town();
    const SimplifyInput in = weldTriangles(scene.triangles);
    const double smallest = smallestBuildingSize(scene);
    const std::set<uint32_t> all_features(in.feature_id.begin(), in.feature_id.end());
    ASSERT_EQ(all_features.size(), scene.features.size());

    size_t previous = std::numeric_limits<size_t>::max(), dropped_at_largest = 0;
    std::printf("town: %zu triangles, %zu welded vertices, smallest building %.2f m\n", in.indices.size() / 3,
                in.positions.size(), smallest);
    for (double bound : {0.05, 0.5, 2.0, 5.0, 10.0, 25.0, 50.0}) {
        SCOPED_TRACE(bound);
        const auto t0 = std::chrono::steady_clock::now();
        // Target 0: the error bound is what stops the reduction.
        const SimplifyResult r = simplifyMesh(in, 0, bound);
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        expectValidIndices(in, r);
        std::printf("  bound %5.2f m: %zu -> %zu triangles (%.1f%%), error %.4f m, %zu features dropped, %.1f ms\n",
                    bound, r.triangles_in, r.triangles_out, 100.0 * r.triangles_out / r.triangles_in,
                    r.geometric_error_m, r.features_dropped.size(), ms);

        EXPECT_LE(r.geometric_error_m, bound);
        const double brute = bruteError(in, r.indices);
        EXPECT_LE(brute, bound);
        EXPECT_NEAR(r.geometric_error_m, brute, 1e-9);

        EXPECT_LE(r.triangles_out, previous) << "a looser bound must not keep more triangles";
        previous = r.triangles_out;

        // No feature lost silently: output features and dropped ones partition the input's.
        const std::set<uint32_t> kept = featuresOf(in, r.indices);
        EXPECT_TRUE(std::is_sorted(r.features_dropped.begin(), r.features_dropped.end()));
        std::set<uint32_t> both = kept;
        for (uint32_t f : r.features_dropped) {
            EXPECT_EQ(kept.count(f), 0u) << "feature " << f << " is listed as dropped but still present";
            both.insert(f);
        }
        EXPECT_EQ(both, all_features);
        if (bound < smallest) {
            EXPECT_TRUE(r.features_dropped.empty());
        }
        dropped_at_largest = r.features_dropped.size();
    }
    // Beyond the smallest building's size buildings fold away: the bounds
    // above must have exercised the dropped-feature bookkeeping, and reduced.
    EXPECT_GT(dropped_at_largest, 0u);
    EXPECT_LT(previous, in.indices.size() / 3 / 2);
}

TEST(Simplify, TownAtATinyBoundKeepsAlmostEverything) {
    const SimplifyInput in = weldTriangles(town().triangles);
    const SimplifyResult r = simplifyMesh(in, 0, 1e-4);
    expectValidIndices(in, r);
    // Collapses that move nothing are still allowed at any bound: a vertex
    // whose faces are all coplanar (inside a flat wall or roof) or that sits
    // on a straight crease between two planes goes at zero error (see
    // SubdividedBoxLosesOnlyItsCoplanarVertices). The synthetic LOD2 solids
    // have vertices only at their corners (polygons are triangulated without
    // extra points), so here nothing may go; 10% leaves room for sources
    // whose walls carry extra coplanar vertices.
    EXPECT_GE(r.triangles_out * 100, r.triangles_in * 90);
    EXPECT_LE(r.geometric_error_m, 1e-4);
    EXPECT_LE(bruteError(in, r.indices), 1e-9);
    EXPECT_TRUE(r.features_dropped.empty());
}

// A 10 m cube whose faces are 2 x 2 grids (8 triangles each): the face centres
// are coplanar with all their neighbours and the edge midpoints lie on a
// straight crease, so all of them can collapse at zero error, down to the 12
// triangles of a plain box, while no corner can move at a 1 micrometre bound.
TEST(Simplify, SubdividedBoxLosesOnlyItsCoplanarVertices) {
    std::vector<Triangle> tris;
    auto face = [&](const Vec3d& o, const Vec3d& u, const Vec3d& v) {  // counter-clockwise seen from outside
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i) {
                const Vec3d p00 = o + (5.0 * i) * u + (5.0 * j) * v, p10 = p00 + 5.0 * u, p01 = p00 + 5.0 * v,
                            p11 = p10 + 5.0 * v;
                Triangle a, b;
                a.position_local = {p00, p10, p11};
                b.position_local = {p00, p11, p01};
                tris.push_back(a);
                tris.push_back(b);
            }
    };
    const Vec3d X{1, 0, 0}, Y{0, 1, 0}, Z{0, 0, 1};
    face({0, 0, 0}, Y, X);    // bottom (z = 0), facing down
    face({0, 0, 10}, X, Y);   // top
    face({0, 0, 0}, X, Z);    // y = 0, facing -y
    face({0, 10, 0}, Z, X);   // y = 10, facing +y
    face({0, 0, 0}, Z, Y);    // x = 0, facing -x
    face({10, 0, 0}, Y, Z);   // x = 10, facing +x
    const SimplifyInput in = weldTriangles(tris);
    ASSERT_EQ(in.positions.size(), 26u);  // 8 corners, 12 edge midpoints, 6 face centres
    const SimplifyResult r = simplifyMesh(in, 0, 1e-6);
    expectValidIndices(in, r);
    EXPECT_EQ(r.triangles_in, 48u);
    EXPECT_EQ(r.triangles_out, 12u);
    EXPECT_LE(r.geometric_error_m, 1e-6);
    EXPECT_LE(bruteError(in, r.indices), 1e-9);
    std::set<Vec3d, bool (*)(const Vec3d&, const Vec3d&)> corners(
        [](const Vec3d& a, const Vec3d& b) { return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z); });
    for (uint32_t i : r.indices) corners.insert(in.positions[i]);
    EXPECT_EQ(corners.size(), 8u);
    for (const Vec3d& p : corners)
        for (double c : {p.x, p.y, p.z}) EXPECT_TRUE(c == 0 || c == 10) << "a non-corner vertex survived";
}

TEST(Simplify, TownTargetBindsBeforeALooseBound) {
    const SimplifyInput in = weldTriangles(town().triangles);
    const size_t n = in.indices.size() / 3;
    // A target at or above the input: nothing to do, error exactly 0.
    const SimplifyResult same = simplifyMesh(in, n, 10.0);
    EXPECT_EQ(same.triangles_out, n);
    EXPECT_EQ(same.geometric_error_m, 0.0);

    // At a bound as large as the town, the target is what stops the reduction.
    size_t previous = 0;
    for (size_t target : {n / 4, n / 2, 3 * n / 4}) {
        SCOPED_TRACE(target);
        const SimplifyResult r = simplifyMesh(in, target, 1000.0);
        expectValidIndices(in, r);
        EXPECT_LE(r.triangles_out, target);
        EXPECT_GE(r.triangles_out, target * 9 / 10) << "meshopt stops at the target, not far below it";
        EXPECT_GE(r.triangles_out, previous) << "a larger target must not keep fewer triangles";
        previous = r.triangles_out;
        EXPECT_NEAR(r.geometric_error_m, bruteError(in, r.indices), 1e-9);
    }
}

TEST(Simplify, BoundWinsOverAnUnreachableTarget) {
    const SimplifyInput in = weldTriangles(town().triangles);
    const SimplifyResult r = simplifyMesh(in, 1, 0.05);
    // One triangle cannot stand for 60 buildings within 5 cm: the result keeps
    // more than the target and says so in triangles_out.
    EXPECT_GT(r.triangles_out, 1u);
    EXPECT_LE(r.geometric_error_m, 0.05);
}

// The town as the tiles stage hands an inner node's merge over: welded
// within each face of each building only (a face is a chart with its own
// atlas uvs), attribute seams kept, so buildings share no vertex and their
// corners, where three charts meet, are locked for meshopt.
SimplifyInput perFaceWeld(const Scene& scene) {
    SimplifyInput in;
    in.keep_attribute_seams = true;
    using Key = std::tuple<uint32_t, long, long, long, double, double, double>;
    std::map<Key, uint32_t> at;
    for (const Triangle& t : scene.triangles) {
        const auto& q = t.position_local;
        Vec3d n = cross(q[1] - q[0], q[2] - q[0]);
        n = (1.0 / std::sqrt(dot(n, n))) * n;
        const long nx = std::lround(n.x * 1e4), ny = std::lround(n.y * 1e4), nz = std::lround(n.z * 1e4);
        for (const Vec3d& p : q) {
            auto [it, inserted] =
                at.emplace(Key{t.feature, nx, ny, nz, p.x, p.y, p.z}, static_cast<uint32_t>(in.positions.size()));
            if (inserted) {
                in.positions.push_back(p);
                in.feature_id.push_back(t.feature);
            }
            in.indices.push_back(it->second);
        }
    }
    return in;
}

TEST(Simplify, AboveTheTargetWholeBuildingsSmallerThanTheirBoundLeaveSmallestFirst) {
    SimplifyInput in = perFaceWeld(town());
    std::map<uint32_t, double> diagonal;  // over the building's own vertices, written here
    {
        std::map<uint32_t, Box3d> box;
        for (uint32_t i : in.indices) box[in.feature_id[i]].extend(in.positions[i]);
        for (const auto& [f, b] : box) diagonal[f] = std::sqrt(dot(b.max - b.min, b.max - b.min));
    }
    std::vector<double> sorted;
    for (const auto& [f, d] : diagonal) sorted.push_back(d);
    std::sort(sorted.begin(), sorted.end());
    const double below = sorted[sorted.size() * 2 / 3];  // up to two thirds of the buildings may go
    const double bound = below / 2;                       // meshopt's own bound, kept apart
    const size_t n = in.indices.size() / 3;
    const size_t target = n / 8;

    const SimplifyResult plain = simplifyMesh(in, target, bound);
    ASSERT_GT(plain.triangles_out, target) << "the locked corners must keep meshopt above the target";
    EXPECT_EQ(plain.features_left_out, 0u);
    in.drop_features_below_m = below;
    const SimplifyResult r = simplifyMesh(in, target, bound);
    expectValidIndices(in, r);
    EXPECT_LT(r.triangles_out, plain.triangles_out);
    EXPECT_LE(r.geometric_error_m, bound);

    std::set<uint32_t> left_out;  // dropped here but not by meshopt alone
    std::set_difference(r.features_dropped.begin(), r.features_dropped.end(), plain.features_dropped.begin(),
                        plain.features_dropped.end(), std::inserter(left_out, left_out.end()));
    ASSERT_FALSE(left_out.empty());
    EXPECT_EQ(r.features_left_out, left_out.size());
    double largest_left_out = 0;
    for (uint32_t f : left_out) {
        EXPECT_LT(diagonal[f], below) << "building " << f << " is not below the size given";
        largest_left_out = std::max(largest_left_out, diagonal[f]);
    }
    EXPECT_NEAR(r.left_out_diagonal_m, largest_left_out, 1e-9);
    // Smallest first: every building still drawn that could have gone is
    // at least as large as every one that went.
    const std::set<uint32_t> drawn = featuresOf(in, r.indices);
    size_t candidates_drawn = 0;
    for (uint32_t f : drawn)
        if (diagonal[f] < below) {
            ++candidates_drawn;
            EXPECT_GE(diagonal[f], largest_left_out) << "building " << f << " was kept before a larger one";
        }
    // The target is met unless no candidate is left to take.
    if (r.triangles_out > target) EXPECT_EQ(candidates_drawn, 0u);
    else EXPECT_LE(r.triangles_out, target);

    // Measured again over what is drawn: the drawn buildings' vertices against
    // the result, and the result's samples against the drawn buildings' input
    // (brute force, as simplify.h defines the error).
    std::vector<uint32_t> drawn_input;
    for (size_t t = 0; t < in.indices.size(); t += 3)
        if (drawn.count(in.feature_id[in.indices[t]]))
            drawn_input.insert(drawn_input.end(), in.indices.begin() + static_cast<std::ptrdiff_t>(t),
                               in.indices.begin() + static_cast<std::ptrdiff_t>(t + 3));
    double worst = 0;
    for (uint32_t v : std::set<uint32_t>(drawn_input.begin(), drawn_input.end()))
        worst = std::max(worst, bruteSurfaceDist(in.positions[v], in.positions, r.indices));
    for (size_t t = 0; t < r.indices.size(); t += 3) {
        const Vec3d& a = in.positions[r.indices[t]];
        const Vec3d& b = in.positions[r.indices[t + 1]];
        const Vec3d& c = in.positions[r.indices[t + 2]];
        for (const Vec3d& s : {a, b, c, 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a), (1.0 / 3.0) * (a + b + c)})
            worst = std::max(worst, bruteSurfaceDist(s, in.positions, drawn_input));
    }
    EXPECT_NEAR(worst, r.geometric_error_m, 1e-9);
    std::printf("  below %.2f m, bound %.2f m, target %zu: meshopt alone %zu triangles, with whole buildings out "
                "%zu (%zu buildings, largest %.2f m), error %.3f m\n",
                below, bound, target, plain.triangles_out, r.triangles_out, left_out.size(), largest_left_out,
                r.geometric_error_m);

    // Never empty: every building below the size, a target of one triangle:
    // one building stays.
    in.drop_features_below_m = 1e6;
    const SimplifyResult one = simplifyMesh(in, 1, bound);
    EXPECT_GT(one.triangles_out, 0u);
    EXPECT_EQ(featuresOf(in, one.indices).size(), 1u);
}

// Buildings are left out before anything is simplified, counting their input
// triangles: when leaving out the smallest one already meets the target, the
// rest is drawn exactly as given (nothing collapses, error 0).
TEST(Simplify, LeavingOutTheSmallestBuildingThatMeetsTheTargetKeepsTheRestAsGiven) {
    SimplifyInput in = perFaceWeld(town());
    std::map<uint32_t, Box3d> box;
    std::map<uint32_t, size_t> triangles;  // by the first corner's feature, as simplify.h counts
    for (uint32_t i : in.indices) box[in.feature_id[i]].extend(in.positions[i]);
    for (size_t t = 0; t < in.indices.size(); t += 3) ++triangles[in.feature_id[in.indices[t]]];
    uint32_t smallest = 0;
    double smallest_diagonal = std::numeric_limits<double>::infinity();
    for (const auto& [f, b] : box) {
        const double d = std::sqrt(dot(b.max - b.min, b.max - b.min));
        if (d < smallest_diagonal) smallest_diagonal = d, smallest = f;
    }
    const size_t n = in.indices.size() / 3;
    in.drop_features_below_m = 1e6;
    const SimplifyResult r = simplifyMesh(in, n - triangles[smallest] + 1, 1.0);  // the rest is below the target
    expectValidIndices(in, r);
    EXPECT_EQ(r.features_left_out, 1u);
    EXPECT_EQ(r.features_dropped, std::vector<uint32_t>{smallest});
    EXPECT_NEAR(r.left_out_diagonal_m, smallest_diagonal, 1e-9);
    EXPECT_EQ(r.triangles_out, n - triangles[smallest]);
    EXPECT_EQ(r.geometric_error_m, 0.0);
}

TEST(Simplify, FlatGridCollapsesToAHandfulAtAnyPositiveBound) {
    // Far from the origin (UTM-sized coordinates): float32 has 0.5 m spacing
    // at 5e6 m, so this fails unless the centre is subtracted in double first.
    const Vec3d origin{690000, 5336000, 200};
    const SimplifyInput in = weldTriangles(flatGrid(100, 100.0, origin));
    ASSERT_EQ(in.indices.size() / 3, 20000u);
    ASSERT_EQ(in.positions.size(), 101u * 101u);
    // Every interior vertex is coplanar with its neighbours and every border
    // vertex but the corners collinear with its border neighbours: all of them
    // go at zero error, whatever the bound.
    for (double bound : {1e-5, 1e-3, 1.0, 10.0}) {
        SCOPED_TRACE(bound);
        const SimplifyResult r = simplifyMesh(in, 0, bound);
        expectValidIndices(in, r);
        EXPECT_LE(r.triangles_out, 8u);
        EXPECT_GE(r.triangles_out, 2u);
        EXPECT_LE(r.geometric_error_m, 1e-6);
        EXPECT_LE(bruteError(in, r.indices), 1e-6);
    }
    // Past the half-diagonal (70.7 m) the square may fold into one triangle
    // when nothing asks for more; a target of 2 keeps the square, at error 0.
    const SimplifyResult folded = simplifyMesh(in, 0, 100.0);
    EXPECT_LE(folded.triangles_out, 2u);
    EXPECT_LE(folded.geometric_error_m, 100.0);
    EXPECT_NEAR(folded.geometric_error_m, bruteError(in, folded.indices), 1e-9);
    const SimplifyResult square = simplifyMesh(in, 2, 100.0);
    EXPECT_EQ(square.triangles_out, 2u);
    EXPECT_LE(square.geometric_error_m, 1e-6);
    EXPECT_LE(bruteError(in, square.indices), 1e-6);
}

TEST(Simplify, UnweldedSoupIsWeldedInside) {
    // The same grid without weldTriangles: every triangle its own island. The
    // internal weld must join them, or no border vertex could collapse.
    SimplifyInput soup;
    for (const Triangle& t : flatGrid(20, 20.0, Vec3d{0, 0, 0}))
        for (const Vec3d& p : t.position_local) {
            soup.indices.push_back(static_cast<uint32_t>(soup.positions.size()));
            soup.positions.push_back(p);
        }
    const SimplifyResult r = simplifyMesh(soup, 0, 0.01);
    expectValidIndices(soup, r);
    EXPECT_LE(r.triangles_out, 8u);
    EXPECT_LE(bruteError(soup, r.indices), 1e-9);
}

TEST(Simplify, EdgeCasesEmptyZeroAreaAndUnboundedInput) {
    const SimplifyResult empty = simplifyMesh({}, 0, 1.0);
    EXPECT_EQ(empty.triangles_in, 0u);
    EXPECT_TRUE(empty.indices.empty());

    // Only a zero-area triangle (two corners at one position): nothing to draw.
    SimplifyInput sliver;
    sliver.positions = {{0, 0, 0}, {1, 0, 0}, {0, 0, 0}};
    sliver.indices = {0, 1, 2};
    sliver.feature_id = {3, 3, 3};
    const SimplifyResult s = simplifyMesh(sliver, 0, 1.0);
    EXPECT_EQ(s.triangles_in, 1u);
    EXPECT_EQ(s.triangles_out, 0u);
    EXPECT_EQ(s.features_dropped, (std::vector<uint32_t>{3}));

    // An infinite bound must not hang, and must not return the empty mesh
    // (whose distance to anything is infinite, "within" an infinite bound):
    // the town folds to a few triangles and the error is still measured.
    const SimplifyInput in = weldTriangles(town().triangles);
    const SimplifyResult r = simplifyMesh(in, 0, std::numeric_limits<double>::infinity());
    expectValidIndices(in, r);
    EXPECT_GT(r.triangles_out, 0u);
    EXPECT_LT(r.triangles_out, r.triangles_in / 10);
    EXPECT_TRUE(std::isfinite(r.geometric_error_m));
    EXPECT_NEAR(r.geometric_error_m, bruteError(in, r.indices), 1e-9);
}

TEST(Simplify, IsDeterministicAcrossRunsAndThreadCounts) {
    const SimplifyInput in = weldTriangles(town().triangles);
    // 10 m: a bound at which many collapses happen (at 0.5 m nothing does).
    const SimplifyResult a = simplifyMesh(in, 0, 10.0);
    ASSERT_LT(a.triangles_out, a.triangles_in);
    const SimplifyResult b = simplifyMesh(in, 0, 10.0);
    SimplifyResult c;
    tbb::task_arena one_thread(1);
    one_thread.execute([&] { c = simplifyMesh(in, 0, 10.0); });
    for (const SimplifyResult* r : {&b, static_cast<const SimplifyResult*>(&c)}) {
        EXPECT_EQ(r->indices, a.indices);
        EXPECT_EQ(r->geometric_error_m, a.geometric_error_m);
        EXPECT_EQ(r->features_dropped, a.features_dropped);
    }
}

}  // namespace
}  // namespace cityatlas::tiles
