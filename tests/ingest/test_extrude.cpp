// SPDX-License-Identifier: GPL-3.0-or-later
// Footprint extrusion checked as a SOLID and against closed forms computed
// here, independently of the roof code:
// * every output polygon is triangulated with triangulatePolygon (no points
//   added, planar to 1e-9 m, V + 2H - 2 triangles = simple), a ground polygon
//   made HERE (footprint at base_z, reversed) closes the solid, and every
//   directed triangle edge a->b must be matched by exactly one b->a.
//   Vertices are compared EXACTLY (bitwise doubles): the extruder promises
//   that a corner shared by two polygons is the same double triple in both,
//   and triangulatePolygon never moves a vertex (its triangles index the
//   input), so any T-junction or rounding mismatch, however small, shows up
//   as an unmatched edge; a snap (1e-9) would hide exactly those defects;
// * the volume (divergence theorem over the triangles) and the roof / wall
//   areas (Newell normals, independent of the triangulation) are compared
//   with closed forms derived in the comments, to 1e-9 relative: the closed
//   forms are exact, the mesh carries only double rounding (~1e-15 relative).
#include "ingest/footprints/extrude.h"

#include "ingest/triangulate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <random>
#include <span>

namespace cityatlas::footprints {
namespace {

constexpr RoofShape kAllShapes[] = {RoofShape::Flat, RoofShape::Shed, RoofShape::Gable, RoofShape::Hip,
                                    RoofShape::Pyramid};

double rel(double expected) { return 1e-9 * std::max(1.0, std::abs(expected)); }

// ---------------------------------------------------------------- footprints

Footprint2d rectangle(double w, double d, double x0 = 0, double y0 = 0) {
    return {{{x0, y0}, {x0 + w, y0}, {x0 + w, y0 + d}, {x0, y0 + d}}, {}};
}

// L: [0,W]x[0,a] u [0,a]x[0,D], both arms of width a.
Footprint2d lShape(double W, double D, double a) { return {{{0, 0}, {W, 0}, {W, a}, {a, a}, {a, D}, {0, D}}, {}}; }

// U: a bar [0,W]x[0,a] and two arms [0,a]x[a,D], [W-a,W]x[a,D], all of width a.
Footprint2d uShape(double W, double D, double a) {
    return {{{0, 0}, {W, 0}, {W, D}, {W - a, D}, {W - a, a}, {a, a}, {a, D}, {0, D}}, {}};
}

// Square S x S with a centred square hole s x s (clockwise).
Footprint2d courtyard(double S, double s) {
    const double o = (S - s) / 2;
    return {{{0, 0}, {S, 0}, {S, S}, {0, S}}, {{{o, o}, {o, o + s}, {o + s, o + s}, {o + s, o}}}};
}

double shoelace(const std::vector<Vec2d>& r) {
    double s = 0;
    for (size_t i = 0; i < r.size(); ++i) {
        const Vec2d& a = r[i];
        const Vec2d& b = r[(i + 1) % r.size()];
        s += a.x * b.y - b.x * a.y;
    }
    return 0.5 * s;
}

// Signed areas: holes are clockwise, so the sum is the net area.
double footprintArea(const Footprint2d& f) {
    double a = shoelace(f.outer);
    for (const auto& h : f.holes) a += shoelace(h);
    return a;
}

// Area of the mitred inward offset of the footprint at offset time tau: every
// vertex moves by tau (n1 + n2) / (1 + n1.n2), n1/n2 the inward unit normals of
// its two edges (the point at distance tau from both offset lines). Valid until
// the first topological event of the offset; for the rectangles, L, U and
// square courtyards used here (all arms of one width a) that event is the
// collapse at tau = a/2, where this area reaches 0. Independent of CGAL.
double mitredOffsetArea(const Footprint2d& f, double tau) {
    auto ringArea = [&](const std::vector<Vec2d>& r) {
        const size_t n = r.size();
        std::vector<Vec2d> moved(n);
        for (size_t i = 0; i < n; ++i) {
            const Vec2d& p = r[(i + n - 1) % n];
            const Vec2d& c = r[i];
            const Vec2d& q = r[(i + 1) % n];
            const double l1 = std::hypot(c.x - p.x, c.y - p.y), l2 = std::hypot(q.x - c.x, q.y - c.y);
            const Vec2d n1{-(c.y - p.y) / l1, (c.x - p.x) / l1};  // left of the edge = building side
            const Vec2d n2{-(q.y - c.y) / l2, (q.x - c.x) / l2};
            const double k = tau / (1 + n1.x * n2.x + n1.y * n2.y);
            moved[i] = {c.x + k * (n1.x + n2.x), c.y + k * (n1.y + n2.y)};
        }
        return shoelace(moved);
    };
    double a = ringArea(f.outer);
    for (const auto& h : f.holes) a += ringArea(h);
    return a;
}

// Layer cake: the volume under an equal-pitch hip roof is
// tan(pitch) * integral of (offset time) over the footprint
// = tan(pitch) * integral_0^tmax A(tau) dtau, with A the mitred offset area.
// A is a quadratic polynomial in tau (vertices move linearly), so Simpson's
// rule on [0, tmax] is exact.
double hipRoofVolume(const Footprint2d& f, double t_max, double r) {
    const double integral =
        t_max / 6 * (mitredOffsetArea(f, 0) + 4 * mitredOffsetArea(f, t_max / 2) + mitredOffsetArea(f, t_max));
    return r / t_max * integral;
}

// ---------------------------------------------------------------- solid check

using Key = std::array<double, 3>;
Key key(const Vec3d& p) { return {p.x, p.y, p.z}; }

struct SolidFigures {
    double volume = 0;
    double roof_area = 0;
    double wall_area = 0;
    size_t roof_polygons = 0;
    size_t wall_polygons = 0;
};

bool allFinite(const ExtrusionResult& res) {
    for (const auto& poly : res.polygons) {
        for (const auto& ring : poly.rings)
            for (const Vec3d& p : ring)
                if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) return false;
        for (const auto& ring : poly.uv)
            for (const Vec2d& t : ring)
                if (!std::isfinite(t.x) || !std::isfinite(t.y)) return false;
    }
    return true;
}

PolygonRings ringsOf(const std::vector<std::vector<Vec3d>>& rings) {
    PolygonRings pr;
    for (const auto& r : rings) pr.rings.emplace_back(r);
    return pr;
}

double areaOf(const ExtrudedPolygon& poly) { return polygonArea(ringsOf(poly.rings)); }

// Triangulates every polygon plus the test's own ground polygon and checks the
// closed, consistently oriented, planar solid; returns volume and areas.
SolidFigures checkClosedSolid(const Footprint2d& fp, const ExtrusionParams& params, const ExtrusionResult& res,
                              const std::string& label) {
    SCOPED_TRACE(label);
    SolidFigures fig;
    EXPECT_TRUE(allFinite(res));
    std::vector<std::vector<std::vector<Vec3d>>> polygons;
    for (const auto& poly : res.polygons) {
        polygons.push_back(poly.rings);
        EXPECT_TRUE(poly.semantic == SurfaceSemantic::Wall || poly.semantic == SurfaceSemantic::Roof);
        if (!poly.uv.empty()) {
            EXPECT_EQ(poly.uv.size(), poly.rings.size());
            for (size_t r = 0; r < poly.uv.size() && r < poly.rings.size(); ++r)
                EXPECT_EQ(poly.uv[r].size(), poly.rings[r].size());
        }
        (poly.semantic == SurfaceSemantic::Roof ? fig.roof_area : fig.wall_area) += areaOf(poly);
        (poly.semantic == SurfaceSemantic::Roof ? fig.roof_polygons : fig.wall_polygons)++;
    }
    // Ground: the footprint at base_z, reversed so that it faces down.
    std::vector<std::vector<Vec3d>> ground;
    auto down = [&](const std::vector<Vec2d>& r) {
        std::vector<Vec3d> g;
        for (auto it = r.rbegin(); it != r.rend(); ++it) g.push_back({it->x, it->y, params.base_z});
        return g;
    };
    ground.push_back(down(fp.outer));
    for (const auto& h : fp.holes) ground.push_back(down(h));
    polygons.push_back(ground);

    std::map<std::pair<Key, Key>, int> edges;
    const Vec3d o{fp.outer[0].x, fp.outer[0].y, params.base_z};
    for (size_t i = 0; i < polygons.size(); ++i) {
        const auto& poly = polygons[i];
        const PolygonTriangulation t = triangulatePolygon(ringsOf(poly));
        EXPECT_FALSE(t.degenerate) << "polygon " << i;
        EXPECT_TRUE(t.added_points.empty()) << "polygon " << i << " crosses itself";
        EXPECT_EQ(t.repeated_vertices, 0u) << "polygon " << i;
        EXPECT_LT(t.max_plane_deviation_m, 1e-9) << "polygon " << i << " is not planar";
        size_t v = 0;
        for (const auto& r : poly) v += r.size();
        EXPECT_EQ(t.triangles.size(), v + 2 * (poly.size() - 1) - 2) << "polygon " << i << " is not simple";
        std::vector<Vec3d> all;
        for (const auto& r : poly) all.insert(all.end(), r.begin(), r.end());
        for (const auto& tri : t.triangles) {
            const Vec3d& a = all[tri[0]];
            const Vec3d& b = all[tri[1]];
            const Vec3d& c = all[tri[2]];
            edges[{key(a), key(b)}]++;
            edges[{key(b), key(c)}]++;
            edges[{key(c), key(a)}]++;
            fig.volume += dot(a - o, cross(b - o, c - o)) / 6;
        }
    }
    size_t bad = 0;
    for (const auto& [e, count] : edges) {
        const auto back = edges.find({e.second, e.first});
        if (count != 1 || back == edges.end() || back->second != 1) {
            if (++bad <= 5)
                ADD_FAILURE() << "edge (" << e.first[0] << "," << e.first[1] << "," << e.first[2] << ")->("
                              << e.second[0] << "," << e.second[1] << "," << e.second[2] << ") used " << count
                              << "x, reverse " << (back == edges.end() ? 0 : back->second) << "x";
        }
    }
    EXPECT_EQ(bad, 0u) << "mesh is not watertight / consistently oriented";
    EXPECT_GT(fig.volume, 0);
    return fig;
}

ExtrusionParams params(RoofShape shape, double base, double h, double r) {
    ExtrusionParams p;
    p.base_z = base;
    p.eave_z = base + h;
    p.ridge_z = base + h + r;
    p.roof = shape;
    return p;
}

Footprint2d transformed(const Footprint2d& f, double angle, double tx, double ty) {
    const double c = std::cos(angle), s = std::sin(angle);
    auto tr = [&](const std::vector<Vec2d>& r) {
        std::vector<Vec2d> out;
        for (const Vec2d& p : r) out.push_back({tx + c * p.x - s * p.y, ty + s * p.x + c * p.y});
        return out;
    };
    Footprint2d out{tr(f.outer), {}};
    for (const auto& h : f.holes) out.holes.push_back(tr(h));
    return out;
}

// ---------------------------------------------------------------- tests

TEST(RoofShape, NamesAndParsing) {
    for (RoofShape s : kAllShapes) { EXPECT_EQ(parseRoofShape(roofShapeName(s)), s); }
    EXPECT_EQ(roofShapeName(RoofShape::Shed), "shed");
    const std::pair<const char*, RoofShape> cases[] = {
        {"flat", RoofShape::Flat},       {"FLAT", RoofShape::Flat},        {"1000", RoofShape::Flat},
        {"skillion", RoofShape::Shed},   {"Mono-Pitch", RoofShape::Shed},  {"shed", RoofShape::Shed},
        {"1010", RoofShape::Shed},       {"gabled", RoofShape::Gable},     {"Gable", RoofShape::Gable},
        {"1030", RoofShape::Gable},      {"hipped", RoofShape::Hip},       {"HIP", RoofShape::Hip},
        {"1040", RoofShape::Hip},        {"pyramidal", RoofShape::Pyramid}, {"pyramid", RoofShape::Pyramid},
        {"1070", RoofShape::Pyramid},    {" hipped ", RoofShape::Hip},
    };
    for (const auto& [text, shape] : cases) { EXPECT_EQ(parseRoofShape(text), shape) << text; }
    for (const char* text : {"", "  ", "dome", "1020", "gambrel", "hipp", "flat roof"})
        EXPECT_FALSE(parseRoofShape(text).has_value()) << text;
}

// Rectangle w x d (w >= d), wall height h, roof height r. Closed forms:
//   flat    V = w d h,                       roof w d
//   shed    V = w d (h + r/2),               roof w sqrt(d^2 + r^2)   (plane rises across d)
//           walls: low long wall w h, high one w (h+r), two trapezoids d (h + r/2)
//   gable   V = w d h + w d r / 2,           roof 2 w sqrt((d/2)^2 + r^2), walls + two triangles d r / 2
//   hip     V = w d h + d r (3w - d) / 6,    roof w d sqrt(1 + (2r/d)^2)  (pitch tan = r / (d/2))
//   pyramid V = w d h + w d r / 3,           roof w sqrt((d/2)^2 + r^2) + d sqrt((w/2)^2 + r^2)
// Hip volume: the roof height is tan(pitch) times the offset time; the offset
// rectangle at time t has area (w-2t)(d-2t); integral_0^{d/2} = d^2 (3w-d)/12,
// times 2r/d.
TEST(Extrude, RectangleClosedForms) {
    const double w = 12, d = 8, h = 9, r = 4, base = 2;
    const struct Placement {
        double angle, tx, ty;
    } placements[] = {{0, 0, 0}, {0.5235987755982988, 1234.5, -2345.25}};
    for (const Placement& pl : placements)
        for (RoofShape shape : kAllShapes) {
            const Footprint2d fp = transformed(rectangle(w, d), pl.angle, pl.tx, pl.ty);
            const ExtrusionParams p = params(shape, base, h, r);
            const ExtrusionResult res = extrudeFootprint(fp, p);
            const std::string label = std::string(roofShapeName(shape)) + " angle " + std::to_string(pl.angle);
            SCOPED_TRACE(label);
            EXPECT_EQ(res.built, shape);
            EXPECT_EQ(res.fallback, "");
            EXPECT_EQ(res.walls_removed, 0u);
            const SolidFigures fig = checkClosedSolid(fp, p, res, label);
            EXPECT_EQ(fig.wall_polygons, 4u);
            double volume = 0, roof = 0, walls = 2 * (w + d) * h;
            size_t roof_polys = 0;
            switch (shape) {
                case RoofShape::Flat: volume = w * d * h, roof = w * d, roof_polys = 1; break;
                case RoofShape::Shed:
                    volume = w * d * (h + r / 2), roof = w * std::sqrt(d * d + r * r), roof_polys = 1;
                    walls = w * h + w * (h + r) + 2 * d * (h + r / 2);
                    break;
                case RoofShape::Gable:
                    volume = w * d * h + w * d * r / 2, roof = 2 * w * std::sqrt(d * d / 4 + r * r), roof_polys = 2;
                    walls += d * r;
                    break;
                case RoofShape::Hip:
                    volume = w * d * h + d * r * (3 * w - d) / 6, roof = w * d * std::sqrt(1 + 4 * r * r / (d * d));
                    roof_polys = 4;
                    break;
                case RoofShape::Pyramid:
                    volume = w * d * h + w * d * r / 3;
                    roof = w * std::sqrt(d * d / 4 + r * r) + d * std::sqrt(w * w / 4 + r * r), roof_polys = 4;
                    break;
            }
            EXPECT_NEAR(fig.volume, volume, rel(volume));
            EXPECT_NEAR(fig.roof_area, roof, rel(roof));
            EXPECT_NEAR(fig.wall_area, walls, rel(walls));
            EXPECT_EQ(fig.roof_polygons, roof_polys);
            if (shape == RoofShape::Hip) {  // the layer-cake helper agrees with the closed form
                EXPECT_NEAR(hipRoofVolume(fp, d / 2, r), d * r * (3 * w - d) / 6, 1e-9);
            }
            // No roof point above the ridge or below the eave; the ridge is reached.
            double zmax = -1e300;
            for (const auto& poly : res.polygons)
                for (const Vec3d& q : poly.rings[0]) {
                    zmax = std::max(zmax, q.z);
                    if (poly.semantic == SurfaceSemantic::Roof) {
                        EXPECT_GE(q.z, p.eave_z - 1e-12);
                        EXPECT_LE(q.z, p.ridge_z + 1e-12);
                    }
                }
            EXPECT_NEAR(zmax, shape == RoofShape::Flat ? p.eave_z : p.ridge_z, 1e-12);
        }
}

// L = [0,W]x[0,a] u [0,a]x[0,D] with W, D > a, wall height h, roof height r.
// Hip: both arms have width a, so the mitred offset collapses at t_max = a/2
// (checked: the offset area is 0 there), the pitch is tan = r / (a/2), and as
// every skeleton face projects onto its part of the footprint,
// roof area = footprint area / cos(pitch) = A sqrt(1 + tan^2).
// Hip volume, derived by hand (layer cake): the offset at time t is again an L,
// with arm width a-2t and outer sides W-2t, D-2t, so its area is
//   A(t) = (a-2t) (W + D - a - 2t).
// With s = a - 2t: integral_0^{a/2} A dt = 1/2 integral_0^a s (W + D - 2a + s) ds
//   = (W + D - 2a) a^2 / 4 + a^3 / 6,
// and V_roof = tan * that = r a^2 / 3 + r a (W + D - 2a) / 2.
// (Cross-check by pieces, for W, D >= 3a/2: corner square a^3/4, each arm
// beyond it a^2 L'/4 - a^3/24 with L' its length beyond the square; same sum.)
// Shed: the longest edge is (0,0)->(W,0) (W > D), the plane rises along +y to
// the farthest vertex y = D: z = eave + r y / D, so
// V = A h + (r / D) integral y dA, integral y dA = W a (a/2) + a (D-a) (D+a)/2.
TEST(Extrude, LShapeClosedForms) {
    const double W = 30, D = 20, a = 8, h = 7, r = 3, base = -1;
    const Footprint2d fp = lShape(W, D, a);
    const double A = W * a + a * (D - a);
    ASSERT_DOUBLE_EQ(footprintArea(fp), A);
    EXPECT_NEAR(mitredOffsetArea(fp, a / 2), 0, 1e-12);
    const double tan_pitch = r / (a / 2);
    const double hip_roof_volume = r * a * a / 3 + r * a * (W + D - 2 * a) / 2;
    EXPECT_NEAR(hipRoofVolume(fp, a / 2, r), hip_roof_volume, 1e-9);  // hand derivation == layer cake

    for (RoofShape shape : kAllShapes) {
        const ExtrusionParams p = params(shape, base, h, r);
        const ExtrusionResult res = extrudeFootprint(fp, p);
        const std::string label(roofShapeName(shape));
        const SolidFigures fig = checkClosedSolid(fp, p, res, label);
        EXPECT_EQ(fig.wall_polygons, 6u);
        const double walls = 2 * (W + D) * h;
        switch (shape) {
            case RoofShape::Flat:
                EXPECT_EQ(res.built, RoofShape::Flat);
                EXPECT_NEAR(fig.volume, A * h, rel(A * h));
                EXPECT_NEAR(fig.roof_area, A, rel(A));
                EXPECT_NEAR(fig.wall_area, walls, rel(walls));
                break;
            case RoofShape::Shed: {
                EXPECT_EQ(res.built, RoofShape::Shed);
                const double int_y = W * a * a / 2 + a * (D - a) * (D + a) / 2;
                const double v = A * h + r / D * int_y;
                EXPECT_NEAR(fig.volume, v, rel(v));
                const double roof = A * std::sqrt(1 + (r / D) * (r / D));  // plane slope r / D
                EXPECT_NEAR(fig.roof_area, roof, rel(roof));
                break;
            }
            case RoofShape::Gable:
            case RoofShape::Pyramid:
                EXPECT_EQ(res.built, RoofShape::Hip);
                EXPECT_NE(res.fallback.find(roofShapeName(shape)), std::string::npos) << res.fallback;
                EXPECT_NE(res.fallback.find("hip"), std::string::npos) << res.fallback;
                [[fallthrough]];
            case RoofShape::Hip: {
                EXPECT_EQ(res.built, RoofShape::Hip);
                if (shape == RoofShape::Hip) { EXPECT_EQ(res.fallback, ""); }
                const double v = A * h + hip_roof_volume;
                EXPECT_NEAR(fig.volume, v, rel(v));
                const double roof = A * std::sqrt(1 + tan_pitch * tan_pitch);
                EXPECT_NEAR(fig.roof_area, roof, rel(roof));
                EXPECT_NEAR(fig.wall_area, walls, rel(walls));
                EXPECT_EQ(fig.roof_polygons, 6u);  // one skeleton face per edge
                break;
            }
        }
    }
}

// U = bar [0,W]x[0,a] plus arms [0,a]x[a,D] and [W-a,W]x[a,D]. Hip volume by
// the layer cake (t_max = a/2 as all arms have width a); shed plane rises along
// +y from the longest edge (0,0)->(W,0): integral y dA = W a^2/2 + 2 a (D-a)(D+a)/2.
TEST(Extrude, UShapeClosedForms) {
    const double W = 30, D = 20, a = 8, h = 6, r = 5, base = 0;
    const Footprint2d fp = uShape(W, D, a);
    const double A = W * a + 2 * a * (D - a);
    ASSERT_DOUBLE_EQ(footprintArea(fp), A);
    EXPECT_NEAR(mitredOffsetArea(fp, a / 2), 0, 1e-12);
    const double tan_pitch = r / (a / 2);
    for (RoofShape shape : kAllShapes) {
        const ExtrusionParams p = params(shape, base, h, r);
        const ExtrusionResult res = extrudeFootprint(fp, p);
        const std::string label(roofShapeName(shape));
        const SolidFigures fig = checkClosedSolid(fp, p, res, label);
        EXPECT_EQ(fig.wall_polygons, 8u);
        if (shape == RoofShape::Flat) { EXPECT_NEAR(fig.volume, A * h, rel(A * h)); }
        if (shape == RoofShape::Shed) {
            const double v = A * h + r / D * (W * a * a / 2 + a * (D - a) * (D + a));
            EXPECT_NEAR(fig.volume, v, rel(v));
        }
        if (shape == RoofShape::Gable || shape == RoofShape::Pyramid || shape == RoofShape::Hip) {
            EXPECT_EQ(res.built, RoofShape::Hip);
            if (shape != RoofShape::Hip) {
                EXPECT_NE(res.fallback.find("built hip"), std::string::npos) << res.fallback;
            }
            const double v = A * h + hipRoofVolume(fp, a / 2, r);
            EXPECT_NEAR(fig.volume, v, rel(v));
            const double roof = A * std::sqrt(1 + tan_pitch * tan_pitch);
            EXPECT_NEAR(fig.roof_area, roof, rel(roof));
        }
    }
}

// Square S with a centred square hole s: a frame of width a = (S-s)/2.
// Hip: the offset at time t is the frame between squares S-2t and s+2t, area
// (S-s-4t)(S+s); integral_0^{a/2} = a^2 (S+s)/2; V_roof = (r/(a/2)) a^2 (S+s)/2
// = r a (S+s) (= triangle profile a r/2 times the centre line 2(S+s)).
// Walls: 4 S h outside plus 4 s h facing into the courtyard.
// Shed: longest edge = the first (all equal), plane rises along +y over S; the
// frame is symmetric about y = S/2, so V = A h + A r / 2.
TEST(Extrude, CourtyardClosedForms) {
    const double S = 40, s = 20, a = (S - s) / 2, h = 10, r = 4, base = 5;
    const Footprint2d fp = courtyard(S, s);
    const double A = S * S - s * s;
    ASSERT_DOUBLE_EQ(footprintArea(fp), A);
    EXPECT_NEAR(hipRoofVolume(fp, a / 2, r), r * a * (S + s), 1e-9);
    for (RoofShape shape : kAllShapes) {
        const ExtrusionParams p = params(shape, base, h, r);
        const ExtrusionResult res = extrudeFootprint(fp, p);
        const std::string label(roofShapeName(shape));
        const SolidFigures fig = checkClosedSolid(fp, p, res, label);
        EXPECT_EQ(fig.wall_polygons, 8u);
        double v = 0;
        switch (shape) {
            case RoofShape::Flat: v = A * h; break;
            case RoofShape::Shed: v = A * h + A * r / 2; break;
            default: v = A * h + r * a * (S + s); break;
        }
        EXPECT_NEAR(fig.volume, v, rel(v));
        if (shape != RoofShape::Shed) { EXPECT_NEAR(fig.wall_area, 4 * (S + s) * h, rel(4 * (S + s) * h)); }
        if (shape == RoofShape::Gable || shape == RoofShape::Pyramid) {
            EXPECT_EQ(res.built, RoofShape::Hip);
            EXPECT_NE(res.fallback.find("holes"), std::string::npos) << res.fallback;
        }
        if (shape == RoofShape::Flat) {  // one roof polygon with the courtyard as its hole
            ASSERT_EQ(fig.roof_polygons, 1u);
            EXPECT_NEAR(fig.roof_area, A, rel(A));
        }
    }
}

TEST(Extrude, KilometreCourtyardHip) {
    // 1020 m square with a 1000 m hole: a 10 m wide frame, 1 km across.
    const double S = 1020, s = 1000, a = 10, h = 12, r = 3;
    const Footprint2d fp = transformed(courtyard(S, s), 0, 5000, -3000);
    const ExtrusionParams p = params(RoofShape::Hip, 100, h, r);
    const ExtrusionResult res = extrudeFootprint(fp, p);
    EXPECT_EQ(res.built, RoofShape::Hip);
    EXPECT_EQ(res.fallback, "");
    const SolidFigures fig = checkClosedSolid(fp, p, res, "1 km courtyard");
    const double A = S * S - s * s;
    const double v = A * h + r * a * (S + s);
    EXPECT_NEAR(fig.volume, v, rel(v));
    const double roof = A * std::sqrt(1 + (2 * r / a) * (2 * r / a));
    EXPECT_NEAR(fig.roof_area, roof, rel(roof));
}

// Collinear vertices (one exactly at a short side's midpoint, others not): the
// shapes are still recognised, the solid stays closed (the extra vertices sit
// in the walls and roofs on both sides), and the rectangle's closed forms hold.
TEST(Extrude, CollinearVerticesKeepShapesAndClosedForms) {
    const double w = 12, d = 8, h = 9, r = 4;
    const Footprint2d fp{{{0, 0}, {5, 0}, {12, 0}, {12, 3}, {12, 8}, {6, 8}, {2, 8}, {0, 8}, {0, 4}}, {}};
    for (RoofShape shape : kAllShapes) {
        const ExtrusionParams p = params(shape, 0, h, r);
        const ExtrusionResult res = extrudeFootprint(fp, p);
        const std::string label(roofShapeName(shape));
        EXPECT_EQ(res.built, shape) << label;
        EXPECT_EQ(res.fallback, "") << label;
        const SolidFigures fig = checkClosedSolid(fp, p, res, label);
        EXPECT_EQ(fig.wall_polygons, 9u) << label;
        double v = 0;
        switch (shape) {
            case RoofShape::Flat: v = w * d * h; break;
            case RoofShape::Shed: v = w * d * (h + r / 2); break;
            case RoofShape::Gable: v = w * d * h + w * d * r / 2; break;
            case RoofShape::Hip: v = w * d * h + d * r * (3 * w - d) / 6; break;
            case RoofShape::Pyramid: v = w * d * h + w * d * r / 3; break;
        }
        EXPECT_NEAR(fig.volume, v, rel(v)) << label;
        if (shape == RoofShape::Gable) {
            const double walls = 2 * (w + d) * h + d * r;
            EXPECT_NEAR(fig.wall_area, walls, rel(walls));
        }
    }
}

// A quadrilateral 1 degree off a rectangle still gets a gable; its roof sides
// are not planar quads, so each is split into two planar polygons.
TEST(Extrude, NearRectangleGableStaysPlanar) {
    const double deg = 3.141592653589793 / 180;
    const Footprint2d fp{{{0, 0}, {12, 0}, {12 + 8 * std::sin(deg), 8 * std::cos(deg)}, {0, 8}}, {}};
    const ExtrusionParams p = params(RoofShape::Gable, 0, 6, 3);
    const ExtrusionResult res = extrudeFootprint(fp, p);
    EXPECT_EQ(res.built, RoofShape::Gable);
    const SolidFigures fig = checkClosedSolid(fp, p, res, "near rectangle");
    EXPECT_EQ(fig.roof_polygons, 4u);
    // 3 degrees off is no rectangle any more.
    const double off = 3 * deg;
    const Footprint2d skew{{{0, 0}, {12, 0}, {12 + 8 * std::sin(off), 8 * std::cos(off)}, {0, 8}}, {}};
    const ExtrusionResult res2 = extrudeFootprint(skew, p);
    EXPECT_EQ(res2.built, RoofShape::Hip);
    EXPECT_NE(res2.fallback.find("gable needs a rectangle"), std::string::npos);
    checkClosedSolid(skew, p, res2, "skewed quad");
}

// L with arms of different widths: horizontal arm [0,W]x[0,a1], vertical arm
// [0,a2]x[0,D], a1 < a2. Here skeleton nodes lie at times between 0 and t_max
// (the narrow arm's ridge at a1/2 < t_max = a2/2), so this checks the height
// interpolation z = eave + r t / t_max, which the equal-width shapes (all nodes
// at t_max) cannot. Mitred offset (= L-infinity erosion for this rectilinear
// shape: a point's time is min(x, y, W-x, D-y, max(a2-x, a1-y))):
//   t <= a1/2: an L, area (W-2t)(a1-2t) + (a2-2t)(D-a1)
//   t >= a1/2: the narrow arm is gone, [t, a2-t]x[t, D-t], area (a2-2t)(D-2t)
// (continuous at a1/2: (a2-a1)(D-a1)). Each piece is quadratic: Simpson exact.
TEST(Extrude, LShapeUnequalArmsHip) {
    const double W = 26, D = 30, a1 = 6, a2 = 10, h = 8, r = 5;
    const Footprint2d fp{{{0, 0}, {W, 0}, {W, a1}, {a2, a1}, {a2, D}, {0, D}}, {}};
    const double A = W * a1 + a2 * (D - a1);
    ASSERT_DOUBLE_EQ(footprintArea(fp), A);
    auto area = [&](double t) {
        return t <= a1 / 2 ? (W - 2 * t) * (a1 - 2 * t) + (a2 - 2 * t) * (D - a1) : (a2 - 2 * t) * (D - 2 * t);
    };
    auto simpson = [&](double t0, double t1) {
        return (t1 - t0) / 6 * (area(t0) + 4 * area((t0 + t1) / 2) + area(t1));
    };
    // The first piece is the generic mitred offset too (before any event).
    EXPECT_NEAR(mitredOffsetArea(fp, a1 / 4), area(a1 / 4), 1e-9);
    const double t_max = a2 / 2, tan_pitch = r / t_max;
    const double roof_volume = tan_pitch * (simpson(0, a1 / 2) + simpson(a1 / 2, t_max));
    for (const auto& [angle, tx] : {std::pair{0.0, 0.0}, std::pair{2.0, 777.0}}) {
        const Footprint2d moved = transformed(fp, angle, tx, -tx);
        const ExtrusionParams p = params(RoofShape::Hip, 3, h, r);
        const ExtrusionResult res = extrudeFootprint(moved, p);
        ASSERT_EQ(res.built, RoofShape::Hip);
        const SolidFigures fig = checkClosedSolid(moved, p, res, "unequal L");
        EXPECT_NEAR(fig.volume, A * h + roof_volume, rel(A * h + roof_volume));
        const double roof = A * std::sqrt(1 + tan_pitch * tan_pitch);
        EXPECT_NEAR(fig.roof_area, roof, rel(roof));
        // The narrow arm's ridge: roof points at height r * (a1/2) / t_max exist.
        bool narrow_ridge = false;
        for (const auto& poly : res.polygons)
            for (const Vec3d& q : poly.rings[0])
                narrow_ridge |=
                    poly.semantic == SurfaceSemantic::Roof && std::abs(q.z - (p.eave_z + r * a1 / a2)) < 1e-9;
        EXPECT_TRUE(narrow_ridge);
    }
}

// The pyramid's apex is the footprint's area centroid (not the vertex mean):
// a trapezoid (0,0) (10,0) (7,4) (3,4): centroid y = (h/3)(b1 + 2 b2)/(b1 + b2)
// with b1 = 10, b2 = 4, h = 4: 4/3 * 18/14 = 12/7; x = 5 by symmetry.
TEST(Extrude, PyramidApexAtAreaCentroid) {
    const Footprint2d fp{{{0, 0}, {10, 0}, {7, 4}, {3, 4}}, {}};
    const ExtrusionParams p = params(RoofShape::Pyramid, 0, 5, 3);
    const ExtrusionResult res = extrudeFootprint(fp, p);
    ASSERT_EQ(res.built, RoofShape::Pyramid);
    const SolidFigures fig = checkClosedSolid(fp, p, res, "trapezoid pyramid");
    EXPECT_NEAR(fig.volume, 28 * 5 + 28 * 3 / 3.0, 1e-9);  // area 28; any apex at height r gives A r / 3
    size_t apexes = 0;
    for (const auto& poly : res.polygons)
        for (const Vec3d& q : poly.rings[0])
            if (q.z == p.ridge_z) {
                ++apexes;
                EXPECT_NEAR(q.x, 5, 1e-12);
                EXPECT_NEAR(q.y, 12.0 / 7.0, 1e-12);
            }
    EXPECT_EQ(apexes, 4u);
}

// Equal pitch and exact cover on random star-shaped footprints (hip), plus the
// closed solid for every shape: no closed form, but two properties independent
// of the skeleton code: every hip face has the same slope, and the faces'
// projections add up to the footprint area.
TEST(Extrude, RandomStarPolygons) {
    std::mt19937 rng(12345);
    std::uniform_real_distribution<double> radius(5, 20), jitter(-0.3, 0.3);
    std::uniform_int_distribution<int> count(5, 16);
    for (int trial = 0; trial < 150; ++trial) {
        const int n = count(rng);
        Footprint2d fp;
        for (int i = 0; i < n; ++i) {
            const double ang = 2 * 3.141592653589793 * (i + 0.5 + jitter(rng)) / n;
            const double rad = radius(rng);
            fp.outer.push_back({300 + rad * std::cos(ang), -700 + rad * std::sin(ang)});
        }
        for (RoofShape shape : kAllShapes) {
            const ExtrusionParams p = params(shape, 1, 8, 4);
            const ExtrusionResult res = extrudeFootprint(fp, p);
            const std::string label = "trial " + std::to_string(trial) + " " + std::string(roofShapeName(shape));
            checkClosedSolid(fp, p, res, label);
            if (res.built != RoofShape::Hip) continue;
            EXPECT_EQ(res.fallback.empty(), shape == RoofShape::Hip) << label << ": " << res.fallback;
            double projected = 0, nz_min = 1, nz_max = 0;
            for (const auto& poly : res.polygons) {
                if (poly.semantic != SurfaceSemantic::Roof) continue;
                const Vec3d nv = newellNormal(poly.rings[0]);
                projected += 0.5 * nv.z;
                const double nz = nv.z / length(nv);
                nz_min = std::min(nz_min, nz), nz_max = std::max(nz_max, nz);
            }
            EXPECT_NEAR(projected, shoelace(fp.outer), 1e-9 * shoelace(fp.outer)) << label;
            EXPECT_LT(nz_max - nz_min, 1e-9) << label << ": pitches differ";
        }
    }
}

// Party walls: edge 1 (a short side) fully covered -> no wall, counted;
// edge 2 (a long side) covered up to base + 3 -> its wall loses exactly w * 3.
// On a gable, an end wall covered up to eave + r/2 keeps only the top of its
// gable triangle: a similar triangle of half size, area (d r / 2) / 4.
TEST(Extrude, PartyWalls) {
    const double w = 12, d = 8, h = 9, r = 4, base = 1;
    const Footprint2d fp = rectangle(w, d);
    ExtrusionParams p = params(RoofShape::Flat, base, h, 0);
    p.wall_bottom_z = {{base, 1000, base + 3, std::nan("")}};
    ExtrusionResult res = extrudeFootprint(fp, p);
    EXPECT_EQ(res.walls_removed, 1u);
    EXPECT_TRUE(allFinite(res));
    double walls = 0;
    size_t wall_count = 0;
    for (const auto& poly : res.polygons)
        if (poly.semantic == SurfaceSemantic::Wall) {
            walls += areaOf(poly);
            ++wall_count;
            for (const Vec3d& q : poly.rings[0]) EXPECT_FALSE(q.x == w && q.y > 0 && q.y < d);  // edge 1: x = w
            for (const Vec3d& q : poly.rings[0]) { EXPECT_GE(q.z, base); }
        }
    EXPECT_EQ(wall_count, 3u);
    EXPECT_NEAR(walls, 2 * (w + d) * h - d * h - w * 3, 1e-9);

    // Gable end wall (edge 1, x = w) raised to the middle of its gable triangle.
    p = params(RoofShape::Gable, base, h, r);
    p.wall_bottom_z = {{std::nan(""), base + h + r / 2}};
    res = extrudeFootprint(fp, p);
    EXPECT_EQ(res.built, RoofShape::Gable);
    EXPECT_EQ(res.walls_removed, 0u);
    walls = 0;
    bool found_triangle = false;
    for (const auto& poly : res.polygons)
        if (poly.semantic == SurfaceSemantic::Wall) {
            walls += areaOf(poly);
            if (poly.rings[0].size() == 3) {
                found_triangle = true;
                EXPECT_NEAR(areaOf(poly), d * r / 8, 1e-12);
            }
        }
    EXPECT_TRUE(found_triangle);
    EXPECT_NEAR(walls, 2 * (w + d) * h + d * r - d * h - (d * r / 2) * 3 / 4, 1e-9);
    // At the ridge height the gable end wall disappears.
    p.wall_bottom_z = {{0, base + h + r}};
    EXPECT_EQ(extrudeFootprint(fp, p).walls_removed, 1u);

    // Hole walls are addressed as ring 1; a footprint given clockwise keeps the
    // caller's edge numbering.
    const Footprint2d yard = courtyard(40, 20);
    p = params(RoofShape::Hip, 0, 10, 3);
    p.wall_bottom_z = {{}, {100, 100}};
    res = extrudeFootprint(yard, p);
    EXPECT_EQ(res.walls_removed, 2u);
    Footprint2d cw = fp;
    std::reverse(cw.outer.begin(), cw.outer.end());  // (0,d) (w,d) (w,0) (0,0): edge 1 is x = w
    p = params(RoofShape::Flat, 0, 10, 0);
    p.wall_bottom_z = {{0, 1000}};
    res = extrudeFootprint(cw, p);
    EXPECT_EQ(res.walls_removed, 1u);
    for (const auto& poly : res.polygons) {
        if (poly.semantic == SurfaceSemantic::Wall) {
            for (const Vec3d& q : poly.rings[0]) { EXPECT_FALSE(q.x == w && q.y > 0 && q.y < d); }
        }
    }
    checkClosedSolid(fp, params(RoofShape::Hip, 0, 10, 3), extrudeFootprint(cw, params(RoofShape::Hip, 0, 10, 3)),
                     "clockwise input");
}

TEST(Extrude, DegenerateInputGivesEmptyResultWithReason) {
    const ExtrusionParams p = params(RoofShape::Hip, 0, 10, 3);
    auto expectEmpty = [](const ExtrusionResult& res, const char* what) {
        EXPECT_TRUE(res.polygons.empty()) << what;
        EXPECT_FALSE(res.fallback.empty()) << what;
        EXPECT_TRUE(allFinite(res)) << what;
    };
    expectEmpty(extrudeFootprint({{{0, 0}, {5, 0}}, {}}, p), "two points");
    expectEmpty(extrudeFootprint({{{0, 0}, {5, 0}, {5, 0}, {0, 0}}, {}}, p), "two distinct points");
    expectEmpty(extrudeFootprint({{{0, 0}, {5, 0}, {10, 0}}, {}}, p), "collinear");
    expectEmpty(extrudeFootprint({}, p), "empty");
    expectEmpty(extrudeFootprint({{{0, 0}, {5, 0}, {std::nan(""), 3}}, {}}, p), "NaN");
    for (RoofShape shape : kAllShapes) {
        ExtrusionParams q = params(shape, 10, 0, 3);  // eave == base
        expectEmpty(extrudeFootprint(rectangle(4, 3), q), "eave == base");
        q.eave_z = 5;  // eave below base
        expectEmpty(extrudeFootprint(rectangle(4, 3), q), "eave < base");
        q = params(shape, 0, 10, 3);
        q.ridge_z = std::numeric_limits<double>::infinity();
        expectEmpty(extrudeFootprint(rectangle(4, 3), q), "infinite ridge");
    }
    // Ridge below the eave: flat, and said so.
    ExtrusionParams q = params(RoofShape::Gable, 0, 10, -2);
    ExtrusionResult res = extrudeFootprint(rectangle(4, 3), q);
    EXPECT_EQ(res.built, RoofShape::Flat);
    EXPECT_NE(res.fallback.find("flat"), std::string::npos);
    checkClosedSolid(rectangle(4, 3), q, res, "ridge below eave");
    // A degenerate hole is ignored (and said so); the building is still made.
    Footprint2d yard = rectangle(10, 10);
    yard.holes.push_back({{3, 3}, {4, 4}, {5, 5}});
    res = extrudeFootprint(yard, params(RoofShape::Hip, 0, 10, 3));
    EXPECT_EQ(res.built, RoofShape::Hip);
    EXPECT_NE(res.fallback.find("hole"), std::string::npos);
    checkClosedSolid(rectangle(10, 10), params(RoofShape::Hip, 0, 10, 3), res, "degenerate hole");
}

TEST(Extrude, SkeletonFailureFallsBackToFlat) {
    // Self-intersecting (invalid) footprint with non-zero area: CGAL refuses it.
    const Footprint2d bad{{{0, 0}, {10, 0}, {10, 10}, {4, 10}, {6, -3}, {0, 4}}, {}};
    const ExtrusionResult res = extrudeFootprint(bad, params(RoofShape::Hip, 0, 10, 3));
    EXPECT_TRUE(allFinite(res));
    EXPECT_EQ(res.built, RoofShape::Flat);
    EXPECT_NE(res.fallback.find("skeleton"), std::string::npos) << res.fallback;
}

// Facade uv: v = (z - base) / (eave - base), so 0 at the base and 1 at the
// eave (gable tops above 1); u = distance along the ring / projection width,
// continuous from one wall to the next. Roof uv: (x - min_x, y - min_y) / size.
TEST(Extrude, TextureCoordinates) {
    const double pw = 3.5, size = 7, base = 2, h = 9, r = 4;
    for (RoofShape shape : kAllShapes)
        for (const Footprint2d& fp : {rectangle(12, 8, 100, 50), lShape(30, 20, 8), courtyard(40, 20)}) {
            ExtrusionParams p = params(shape, base, h, r);
            p.projection_width_m = pw;
            p.roof_texture_size_m = size;
            const ExtrusionResult res = extrudeFootprint(fp, p);
            const std::string label(roofShapeName(res.built));
            SCOPED_TRACE(label);
            double min_x = 1e300, min_y = 1e300;
            for (const Vec2d& q : fp.outer) min_x = std::min(min_x, q.x), min_y = std::min(min_y, q.y);
            // u of each wall's start and end corner, keyed by the 2D corner.
            std::map<std::pair<double, double>, std::vector<double>> u_start, u_end;
            for (const auto& poly : res.polygons) {
                ASSERT_EQ(poly.uv.size(), poly.rings.size());
                const auto& ring = poly.rings[0];
                const auto& uv = poly.uv[0];
                ASSERT_EQ(uv.size(), ring.size());
                if (poly.semantic == SurfaceSemantic::Roof) {
                    for (size_t rr = 0; rr < poly.rings.size(); ++rr)
                        for (size_t i = 0; i < poly.rings[rr].size(); ++i) {
                            EXPECT_NEAR(poly.uv[rr][i].x, (poly.rings[rr][i].x - min_x) / size, 1e-12);
                            EXPECT_NEAR(poly.uv[rr][i].y, (poly.rings[rr][i].y - min_y) / size, 1e-12);
                        }
                    continue;
                }
                for (size_t i = 0; i < ring.size(); ++i) {
                    EXPECT_NEAR(uv[i].y, (ring[i].z - base) / h, 1e-12);
                    if (ring[i].z == base) { EXPECT_EQ(uv[i].y, 0.0); }
                    if (ring[i].z == base + h) { EXPECT_NEAR(uv[i].y, 1.0, 1e-15); }
                }
                // Bottom corners: ring[0] = start, ring[1] = end of the edge (documented order).
                ASSERT_EQ(ring[0].z, base);
                ASSERT_EQ(ring[1].z, base);
                const double len = std::hypot(ring[1].x - ring[0].x, ring[1].y - ring[0].y);
                EXPECT_NEAR(uv[1].x - uv[0].x, len / pw, 1e-12);
                // Vertical sides: same u at the bottom and the top of a corner.
                for (size_t i = 0; i < ring.size(); ++i)
                    for (size_t j = 0; j < ring.size(); ++j) {
                        if (ring[i].x == ring[j].x && ring[i].y == ring[j].y) { EXPECT_EQ(uv[i].x, uv[j].x); }
                    }
                u_start[{ring[0].x, ring[0].y}].push_back(uv[0].x);
                u_end[{ring[1].x, ring[1].y}].push_back(uv[1].x);
                if (res.built == RoofShape::Gable) {
                    for (size_t i = 0; i < ring.size(); ++i) {
                        if (ring[i].z == base + h + r) { EXPECT_NEAR(uv[i].y, (h + r) / h, 1e-12); }
                    }
                }
            }
            // Continuity: where one wall ends the next starts with the same u,
            // except at each ring's first vertex (u wraps from the perimeter to 0).
            size_t matched = 0, wrapped = 0;
            for (const auto& [corner, ends] : u_end) {
                ASSERT_EQ(ends.size(), 1u);
                ASSERT_EQ(u_start[corner].size(), 1u);
                if (u_start[corner][0] == ends[0]) ++matched;
                else {
                    ++wrapped;
                    EXPECT_EQ(u_start[corner][0], 0.0);
                }
            }
            EXPECT_EQ(wrapped, 1 + fp.holes.size());
            EXPECT_EQ(matched + wrapped, fp.outer.size() + (fp.holes.empty() ? 0 : fp.holes[0].size()));
        }
    // No texture sizes: no uv at all.
    const ExtrusionResult plain = extrudeFootprint(rectangle(4, 3), params(RoofShape::Hip, 0, 3, 1));
    for (const auto& poly : plain.polygons) { EXPECT_TRUE(poly.uv.empty()); }
}

// Random L-shapes (arm width a, outer sides W, D > a), rotated and moved
// about: each volume against the layer-cake closed form of LShapeClosedForms,
// V = A h + r a^2 / 3 + r a (W + D - 2a) / 2 (valid for any W, D >= a: the
// offset stays an L until it collapses at a/2).
TEST(Extrude, RandomLShapesHipVolume) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> arm(4, 12), len(1.05, 4), angle(0, 6.283185307179586),
        shift(-3000, 3000);
    const double h = 9, r = 4;
    for (int i = 0; i < 300; ++i) {
        const double a = arm(rng), W = a * len(rng), D = a * len(rng);
        const Footprint2d fp = transformed(lShape(W, D, a), angle(rng), shift(rng), shift(rng));
        const ExtrusionParams p = params(RoofShape::Hip, 0, h, r);
        const ExtrusionResult res = extrudeFootprint(fp, p);
        ASSERT_EQ(res.built, RoofShape::Hip) << res.fallback;
        const SolidFigures fig = checkClosedSolid(fp, p, res, "L " + std::to_string(i));
        const double A = W * a + a * (D - a);
        const double v = A * h + r * a * a / 3 + r * a * (W + D - 2 * a) / 2;
        EXPECT_NEAR(fig.volume, v, rel(v)) << i;
        EXPECT_EQ(fig.roof_polygons, 6u);
    }
}

// Throughput benchmark (disabled by default; run with
// --gtest_also_run_disabled_tests --gtest_filter='*Benchmark*'): 10,000
// L-shaped hip roofs, rotated and moved about and rounded to millimetres like
// surveyed footprints.
TEST(Extrude, DISABLED_BenchmarkTenThousandLShapedHipRoofs) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> arm(4, 12), len(1.6, 4), angle(0, 6.283185307179586), shift(-3000, 3000);
    std::vector<Footprint2d> footprints;
    for (int i = 0; i < 10000; ++i) {
        const double a = arm(rng);
        Footprint2d fp = transformed(lShape(a * len(rng), a * len(rng), a), angle(rng), shift(rng), shift(rng));
        for (Vec2d& q : fp.outer) q = {std::round(q.x * 1000) / 1000, std::round(q.y * 1000) / 1000};
        footprints.push_back(std::move(fp));
    }
    const auto t0 = std::chrono::steady_clock::now();
    size_t polygons = 0, hips = 0;
    for (const Footprint2d& fp : footprints) {
        const ExtrusionResult res = extrudeFootprint(fp, params(RoofShape::Hip, 0, 9, 4));
        polygons += res.polygons.size();
        hips += res.built == RoofShape::Hip;
    }
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_EQ(hips, 10000u);
    EXPECT_EQ(polygons, 120000u);
    RecordProperty("seconds_for_10000_L_hip_roofs", std::to_string(s));
    std::printf("[ perf ] 10,000 L-shaped hip roofs: %.3f s (%.1f us each)\n", s, s * 1e6 / 10000);
}

}  // namespace
}  // namespace cityatlas::footprints
