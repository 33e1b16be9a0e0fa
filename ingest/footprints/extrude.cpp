// SPDX-License-Identifier: GPL-3.0-or-later
// CGAL is header-only and slow to compile: the straight skeleton stays in this
// one file (see ingest/footprints/extrude.h for what is built and why).
#include "ingest/footprints/extrude.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2.h>
#include <CGAL/Polygon_with_holes_2.h>
#include <CGAL/create_straight_skeleton_from_polygon_with_holes_2.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <exception>
#include <numbers>
#include <unordered_map>

namespace cityatlas::footprints {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

// Distances below this count as "the same line / the same point" where shapes
// are classified (collinear vertices, a footprint vertex at a ridge end).
constexpr double kLinearTolM = 1e-9;
// A gable roof side whose far ridge end lies further than this from the plane
// of its eave and near ridge end is split into two planar polygons.
constexpr double kPlanarSplitTolM = 1e-10;
// Straight-skeleton nodes closer than this are one node (simultaneous events).
constexpr double kNodeMergeTolM = 1e-9;

bool isFinite(const Vec2d& p) { return std::isfinite(p.x) && std::isfinite(p.y); }
Vec2d sub(const Vec2d& a, const Vec2d& b) { return {a.x - b.x, a.y - b.y}; }
double dot2(const Vec2d& a, const Vec2d& b) { return a.x * b.x + a.y * b.y; }
double cross2(const Vec2d& a, const Vec2d& b) { return a.x * b.y - a.y * b.x; }
double len2(const Vec2d& a) { return std::hypot(a.x, a.y); }

// Shoelace, relative to the first vertex (small cross terms far from the origin).
double signedArea(const std::vector<Vec2d>& r) {
    double s = 0;
    for (size_t i = 1; i + 1 < r.size(); ++i) s += cross2(sub(r[i], r[0]), sub(r[i + 1], r[0]));
    return 0.5 * s;
}

void addReason(std::string& to, std::string_view why) {
    if (!to.empty()) to += "; ";
    to += why;
}

// One footprint ring as the builders see it: right orientation (outer CCW,
// holes CW), consecutive duplicates removed, and for every edge the caller's
// edge index (for wall_bottom_z).
struct Ring {
    std::vector<Vec2d> p;
    size_t input_ring = 0;
    std::vector<size_t> input_edge;
    size_t size() const { return p.size(); }
    const Vec2d& at(size_t k) const { return p[k % p.size()]; }
};

// Removes consecutive duplicates (and a closing duplicate); an edge keeps the
// index of the caller's edge that actually leaves the vertex (the last of a run
// of duplicates).
Ring makeRing(const std::vector<Vec2d>& in, size_t input_ring) {
    Ring r;
    r.input_ring = input_ring;
    const size_t n = in.size();
    for (size_t i = 0; i < n; ++i) {
        if (!r.p.empty() && in[i] == r.p.back()) {
            r.input_edge.back() = i;
            continue;
        }
        r.p.push_back(in[i]);
        r.input_edge.push_back(i);
    }
    // A closing duplicate: the last kept vertex's edge (to the duplicate) already ends at the first point.
    while (r.p.size() > 1 && r.p.back() == r.p.front()) {
        r.p.pop_back();
        r.input_edge.pop_back();
    }
    return r;
}

void reverseRing(Ring& r) {
    const size_t n = r.p.size();
    std::vector<size_t> edges(n);
    // Reversed edge k runs from old vertex n-1-k to old vertex n-2-k: old edge (n-2-k) mod n.
    for (size_t k = 0; k < n; ++k) edges[k] = r.input_edge[(2 * n - 2 - k) % n];
    std::reverse(r.p.begin(), r.p.end());
    r.input_edge = std::move(edges);
}

// A point on a wall's top profile or outline: its position along the edge
// (0 at the edge's start, 1 at its end) and the 3D point.
struct ProfilePoint {
    double lam = 0;
    Vec3d p;
};

// What a roof builder produces.
struct Roof {
    RoofShape shape = RoofShape::Flat;
    std::vector<std::vector<double>> vertex_z;  // per ring, per vertex: the roof's z above it
    // Per ring, per edge: points of the roof edge strictly between the edge's
    // ends (increasing lam), e.g. a gable's ridge end.
    std::vector<std::vector<std::vector<ProfilePoint>>> edge_extra;
    std::vector<std::vector<std::vector<Vec3d>>> faces;  // polygons (rings)
};

Roof emptyRoof(const std::vector<Ring>& rings, RoofShape shape, double z) {
    Roof roof;
    roof.shape = shape;
    for (const Ring& r : rings) {
        roof.vertex_z.emplace_back(r.size(), z);
        roof.edge_extra.emplace_back(r.size());
    }
    return roof;
}

Vec3d lift(const std::vector<Ring>& rings, const Roof& roof, size_t r, size_t k) {
    const Vec2d& p = rings[r].p[k];
    return {p.x, p.y, roof.vertex_z[r][k]};
}

// Flat and shed: the footprint itself, lifted by vertex_z.
void footprintFace(const std::vector<Ring>& rings, Roof& roof) {
    std::vector<std::vector<Vec3d>> face;
    for (size_t r = 0; r < rings.size(); ++r) {
        std::vector<Vec3d> ring;
        for (size_t k = 0; k < rings[r].size(); ++k) ring.push_back(lift(rings, roof, r, k));
        face.push_back(std::move(ring));
    }
    roof.faces.push_back(std::move(face));
}

Roof flatRoof(const std::vector<Ring>& rings, double eave) {
    Roof roof = emptyRoof(rings, RoofShape::Flat, eave);
    footprintFace(rings, roof);
    return roof;
}

Roof shedRoof(const std::vector<Ring>& rings, double eave, double ridge) {
    const Ring& outer = rings[0];
    size_t longest = 0;
    double longest_len = -1;
    for (size_t k = 0; k < outer.size(); ++k) {
        const double l = len2(sub(outer.at(k + 1), outer.at(k)));
        if (l > longest_len) longest_len = l, longest = k;
    }
    const Vec2d a = outer.at(longest);
    const Vec2d dir = sub(outer.at(longest + 1), a);
    const Vec2d inward{-dir.y / longest_len, dir.x / longest_len};  // left of a CCW edge
    double dmin = 0, dmax = 0;
    for (const Ring& r : rings)
        for (const Vec2d& p : r.p) {
            const double d = dot2(sub(p, a), inward);
            dmin = std::min(dmin, d);
            dmax = std::max(dmax, d);
        }
    const double span = dmax - dmin;  // > 0 for a footprint with area
    Roof roof = emptyRoof(rings, RoofShape::Shed, eave);
    for (size_t r = 0; r < rings.size(); ++r)
        for (size_t k = 0; k < rings[r].size(); ++k) {
            const double f = (dot2(sub(rings[r].p[k], a), inward) - dmin) / span;
            roof.vertex_z[r][k] = f >= 1 ? ridge : eave + (ridge - eave) * std::clamp(f, 0.0, 1.0);
        }
    footprintFace(rings, roof);
    return roof;
}

// Gable on a rectangle (outer ring only, no holes); nullopt when the footprint
// is no rectangle.
std::optional<Roof> gableRoof(const std::vector<Ring>& rings, double eave, double ridge) {
    if (rings.size() != 1) return std::nullopt;
    const Ring& ring = rings[0];
    const size_t n = ring.size();
    std::vector<size_t> corners;
    for (size_t k = 0; k < n; ++k) {
        const Vec2d prev = ring.at(k + n - 1), cur = ring.p[k], next = ring.at(k + 1);
        const Vec2d chord = sub(next, prev);
        const double chord_len = len2(chord);
        const bool collinear = chord_len > 0 && std::abs(cross2(sub(cur, prev), chord)) / chord_len <= kLinearTolM &&
                               dot2(sub(cur, prev), sub(next, cur)) > 0;
        if (!collinear) corners.push_back(k);
    }
    if (corners.size() != 4) return std::nullopt;
    const double max_cos = std::sin(kGableRightAngleToleranceDeg * std::numbers::pi / 180.0);
    double side_len[4];
    for (int j = 0; j < 4; ++j) {
        const Vec2d a = ring.p[corners[j]], b = ring.p[corners[(j + 1) % 4]], c = ring.p[corners[(j + 2) % 4]];
        const Vec2d in = sub(b, a), out = sub(c, b);
        const double li = len2(in), lo = len2(out);
        if (!(li > 0 && lo > 0)) return std::nullopt;
        if (!(cross2(in, out) > 0) || std::abs(dot2(in, out)) / (li * lo) > max_cos) return std::nullopt;
        side_len[j] = li;
        // Every vertex between two corners must lie on the side between them.
        for (size_t q = (corners[j] + 1) % n; q != corners[(j + 1) % 4]; q = (q + 1) % n)
            if (std::abs(cross2(sub(ring.p[q], a), in)) / li > kLinearTolM) return std::nullopt;
    }
    // The ridge runs along the longer axis: sides 0 and 2 (c0->c1, c2->c3) are the long ones.
    if (side_len[1] + side_len[3] > side_len[0] + side_len[2])
        std::rotate(corners.begin(), corners.begin() + 1, corners.end());
    size_t c[4];
    for (int j = 0; j < 4; ++j) c[j] = corners[j];

    Roof roof = emptyRoof(rings, RoofShape::Gable, eave);
    const double height = ridge - eave;
    // One short side (from corner cs to corner ce): heights above its vertices,
    // its ridge end, and which vertices lie below / above the ridge end.
    struct ShortSide {
        Vec3d ridge_end;
        std::vector<size_t> low;   // interior vertices with lambda < 1/2 (in ring order)
        std::vector<size_t> high;  // interior vertices with lambda > 1/2 (in ring order)
    };
    auto shortSide = [&](size_t cs, size_t ce) {
        ShortSide s;
        const Vec2d A = ring.p[cs], B = ring.p[ce], AB = sub(B, A);
        const double l2 = dot2(AB, AB), l = std::sqrt(l2);
        std::vector<std::pair<size_t, double>> chain{{cs, 0.0}};
        bool snapped = false;
        for (size_t q = (cs + 1) % n; q != ce; q = (q + 1) % n) {
            const double lam = std::clamp(dot2(sub(ring.p[q], A), AB) / l2, 0.0, 1.0);
            if (!snapped && std::abs(lam - 0.5) * l <= kLinearTolM) {
                // A footprint vertex at the ridge end: it is the ridge end.
                snapped = true;
                roof.vertex_z[0][q] = ridge;
                s.ridge_end = {ring.p[q].x, ring.p[q].y, ridge};
                chain.emplace_back(q, 0.5);
                continue;
            }
            roof.vertex_z[0][q] = std::clamp(eave + height * (1 - std::abs(2 * lam - 1)), eave, ridge);
            (lam < 0.5 ? s.low : s.high).push_back(q);
            chain.emplace_back(q, lam);
        }
        chain.emplace_back(ce, 1.0);
        if (!snapped) {
            s.ridge_end = {0.5 * (A.x + B.x), 0.5 * (A.y + B.y), ridge};
            for (size_t i = 0; i + 1 < chain.size(); ++i)
                if (chain[i].second < 0.5 && chain[i + 1].second > 0.5) {
                    const double local = (0.5 - chain[i].second) / (chain[i + 1].second - chain[i].second);
                    roof.edge_extra[0][chain[i].first].push_back({local, s.ridge_end});
                    break;
                }
        }
        return s;
    };
    const ShortSide s12 = shortSide(c[1], c[2]);
    const ShortSide s30 = shortSide(c[3], c[0]);

    auto chainLifted = [&](size_t from, size_t to, std::vector<Vec3d>& out) {
        for (size_t q = from;; q = (q + 1) % n) {
            out.push_back(lift(rings, roof, 0, q));
            if (q == to) break;
        }
    };
    auto append = [&](const std::vector<size_t>& idx, std::vector<Vec3d>& out) {
        for (size_t q : idx) out.push_back(lift(rings, roof, 0, q));
    };
    // One roof side: eave chain from corner e0 to e1, up the near gable to its
    // ridge end, along the ridge, down the far gable. Split along the diagonal
    // e0 -> near ridge end when the four corners are not coplanar.
    auto side = [&](size_t e0, size_t e1, const ShortSide& near, const ShortSide& far) {
        std::vector<Vec3d> first;
        chainLifted(e0, e1, first);
        append(near.low, first);
        first.push_back(near.ridge_end);
        std::vector<Vec3d> second;
        append(far.high, second);
        const Vec3d p0 = lift(rings, roof, 0, e0), p1 = lift(rings, roof, 0, e1);
        const Vec3d nrm = cross(p1 - p0, near.ridge_end - p0);
        const double nl = length(nrm);
        const double dev = nl > 0 ? std::abs(dot(far.ridge_end - p0, nrm)) / nl : 0.0;
        if (dev > kPlanarSplitTolM) {
            roof.faces.push_back({first});
            std::vector<Vec3d> tri{p0, near.ridge_end, far.ridge_end};
            tri.insert(tri.end(), second.begin(), second.end());
            roof.faces.push_back({tri});
        } else {
            first.push_back(far.ridge_end);
            first.insert(first.end(), second.begin(), second.end());
            roof.faces.push_back({first});
        }
    };
    side(c[0], c[1], s12, s30);
    side(c[2], c[3], s30, s12);
    return roof;
}

// Pyramid: convex outer ring, no holes; nullopt otherwise.
std::optional<Roof> pyramidRoof(const std::vector<Ring>& rings, double eave, double ridge) {
    if (rings.size() != 1) return std::nullopt;
    const Ring& ring = rings[0];
    const size_t n = ring.size();
    for (size_t k = 0; k < n; ++k) {
        const Vec2d e1 = sub(ring.p[k], ring.at(k + n - 1)), e2 = sub(ring.at(k + 1), ring.p[k]);
        if (cross2(e1, e2) < -1e-12 * len2(e1) * len2(e2)) return std::nullopt;  // reflex corner
    }
    // Area centroid (relative to the first vertex).
    const Vec2d o = ring.p[0];
    double a2 = 0, cx = 0, cy = 0;
    for (size_t k = 1; k + 1 < n; ++k) {
        const Vec2d p = sub(ring.p[k], o), q = sub(ring.p[k + 1], o);
        const double w = cross2(p, q);
        a2 += w;
        cx += w * (p.x + q.x);
        cy += w * (p.y + q.y);
    }
    if (!(a2 > 0)) return std::nullopt;
    const Vec3d apex{o.x + cx / (3 * a2), o.y + cy / (3 * a2), ridge};
    Roof roof = emptyRoof(rings, RoofShape::Pyramid, eave);
    for (size_t k = 0; k < n; ++k)
        roof.faces.push_back({{lift(rings, roof, 0, k), lift(rings, roof, 0, (k + 1) % n), apex}});
    return roof;
}

// Hip: CGAL's interior straight skeleton, every face lifted by offset time.
// CGAL gets the footprint relative to a local origin (its predicates stay in
// the fast filtered path more often with small coordinates: about 40 % faster
// on buildings 1-3 km from the origin); skeleton nodes are moved back, and
// contour vertices are replaced by the caller's exact footprint points so
// that roof and walls share bit-identical corners.
std::optional<Roof> hipRoof(const std::vector<Ring>& rings, double eave, double ridge) {
    const Vec2d origin = rings[0].p[0];
    std::vector<std::pair<std::pair<double, double>, Vec2d>> contour;  // local point -> footprint point
    auto toCgal = [&](const Ring& r) {
        CGAL::Polygon_2<Kernel> poly;
        for (const Vec2d& p : r.p) {
            const Vec2d local = sub(p, origin);
            contour.push_back({{local.x, local.y}, p});
            poly.push_back(Kernel::Point_2(local.x, local.y));
        }
        return poly;
    };
    try {
        CGAL::Polygon_with_holes_2<Kernel> pwh(toCgal(rings[0]));
        for (size_t r = 1; r < rings.size(); ++r) pwh.add_hole(toCgal(rings[r]));
        std::sort(contour.begin(), contour.end(),
                  [](const auto& a, const auto& b) { return a.first < b.first; });
        for (size_t i = 1; i < contour.size(); ++i)
            if (contour[i].first == contour[i - 1].first) return std::nullopt;  // vertices merged
        const auto skeleton = CGAL::create_interior_straight_skeleton_2(pwh, Kernel());
        if (!skeleton) return std::nullopt;
        if (skeleton->size_of_faces() != contour.size()) return std::nullopt;
        // Skeleton nodes. Simultaneous events can come out as two nodes joined
        // by a (near) zero-length skeleton edge whose rounded times differ in
        // the last bit; such clusters become one node (mean position and time),
        // so that every face meeting there gets the same corner.
        std::unordered_map<const void*, size_t> node_index;
        std::vector<Vec2d> node_xy;
        std::vector<double> node_t;
        double t_max = 0;
        for (auto v = skeleton->vertices_begin(); v != skeleton->vertices_end(); ++v) {
            const double t = v->time();
            if (!std::isfinite(t) || !std::isfinite(v->point().x()) || !std::isfinite(v->point().y()) || t < 0)
                return std::nullopt;
            t_max = std::max(t_max, t);
            if (v->is_contour()) continue;
            node_index.emplace(&*v, node_xy.size());
            node_xy.push_back({v->point().x(), v->point().y()});
            node_t.push_back(t);
        }
        if (!(t_max > 0)) return std::nullopt;
        std::vector<size_t> parent(node_xy.size());
        for (size_t i = 0; i < parent.size(); ++i) parent[i] = i;
        auto find = [&](size_t i) {
            while (parent[i] != i) i = parent[i] = parent[parent[i]];
            return i;
        };
        for (auto h = skeleton->halfedges_begin(); h != skeleton->halfedges_end(); ++h) {
            const auto a = h->vertex(), b = h->opposite()->vertex();
            if (a->is_contour() || b->is_contour()) continue;
            const size_t ia = node_index.at(&*a), ib = node_index.at(&*b);
            if (len2(sub(node_xy[ia], node_xy[ib])) <= kNodeMergeTolM) parent[find(ia)] = find(ib);
        }
        std::vector<Vec2d> sum_xy(node_xy.size());
        std::vector<double> sum_t(node_xy.size(), 0.0), count(node_xy.size(), 0.0);
        for (size_t i = 0; i < node_xy.size(); ++i) {
            const size_t c = find(i);
            sum_xy[c] = {sum_xy[c].x + node_xy[i].x, sum_xy[c].y + node_xy[i].y};
            sum_t[c] += node_t[i];
            count[c] += 1;
        }
        const double height = ridge - eave;
        std::vector<Vec3d> node_out(node_xy.size());
        for (size_t i = 0; i < node_xy.size(); ++i) {
            const size_t c = find(i);
            const double x = count[c] == 1 ? node_xy[c].x : sum_xy[c].x / count[c];
            const double y = count[c] == 1 ? node_xy[c].y : sum_xy[c].y / count[c];
            const double t = count[c] == 1 ? node_t[c] : sum_t[c] / count[c];
            node_out[i] = {x + origin.x, y + origin.y, t >= t_max ? ridge : eave + height * (t / t_max)};
        }
        Roof roof = emptyRoof(rings, RoofShape::Hip, eave);
        for (auto f = skeleton->faces_begin(); f != skeleton->faces_end(); ++f) {
            std::vector<Vec3d> ring;
            auto h = f->halfedge();
            const auto start = h;
            do {
                const auto v = h->vertex();
                Vec3d p;
                if (v->is_contour()) {
                    const std::pair<double, double> k{v->point().x(), v->point().y()};
                    const auto it = std::lower_bound(contour.begin(), contour.end(), k,
                                                     [](const auto& e, const auto& key) { return e.first < key; });
                    if (it == contour.end() || it->first != k) return std::nullopt;
                    p = {it->second.x, it->second.y, eave};
                } else {
                    p = node_out[node_index.at(&*v)];
                }
                if (ring.empty() || !(ring.back() == p)) ring.push_back(p);
                h = h->next();
            } while (h != start);
            while (ring.size() > 1 && ring.back() == ring.front()) ring.pop_back();
            if (ring.size() < 3) return std::nullopt;
            // Start at the contour edge's first vertex (the loop began at its end).
            std::rotate(ring.begin(), ring.end() - 1, ring.end());
            roof.faces.push_back({std::move(ring)});
        }
        return roof;
    } catch (const std::exception&) {
        return std::nullopt;  // CGAL precondition failure (not a simple polygon)
    }
}

// Clips a convex polygon (in the wall's (lam, z) terms) to z >= bottom.
std::vector<ProfilePoint> clipAbove(const std::vector<ProfilePoint>& poly, double bottom, const Vec2d& a,
                                    const Vec2d& b) {
    std::vector<ProfilePoint> out;
    const size_t n = poly.size();
    for (size_t i = 0; i < n; ++i) {
        const ProfilePoint& P = poly[i];
        const ProfilePoint& Q = poly[(i + 1) % n];
        const bool p_in = P.p.z >= bottom, q_in = Q.p.z >= bottom;
        if (p_in) out.push_back(P);
        if (p_in != q_in) {
            const double t = (bottom - P.p.z) / (Q.p.z - P.p.z);
            ProfilePoint X;
            X.lam = P.lam == Q.lam ? P.lam : P.lam + t * (Q.lam - P.lam);
            if (P.lam == Q.lam) X.p = {P.p.x, P.p.y, bottom};
            else if (X.lam <= 0) X.p = {a.x, a.y, bottom}, X.lam = 0;
            else if (X.lam >= 1) X.p = {b.x, b.y, bottom}, X.lam = 1;
            else X.p = {a.x + X.lam * (b.x - a.x), a.y + X.lam * (b.y - a.y), bottom};
            out.push_back(X);
        }
    }
    return out;
}

}  // namespace

std::string_view roofShapeName(RoofShape shape) {
    switch (shape) {
        case RoofShape::Flat: return "flat";
        case RoofShape::Shed: return "shed";
        case RoofShape::Gable: return "gable";
        case RoofShape::Hip: return "hip";
        case RoofShape::Pyramid: return "pyramid";
    }
    return "flat";
}

std::optional<RoofShape> parseRoofShape(std::string_view s) {
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    std::string w(s);
    for (char& ch : w) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    if (w == "flat" || w == "1000") return RoofShape::Flat;
    if (w == "shed" || w == "skillion" || w == "mono-pitch" || w == "monopitch" || w == "mono_pitch" ||
        w == "mono pitch" || w == "1010")
        return RoofShape::Shed;
    if (w == "gable" || w == "gabled" || w == "1030") return RoofShape::Gable;
    if (w == "hip" || w == "hipped" || w == "1040") return RoofShape::Hip;
    if (w == "pyramid" || w == "pyramidal" || w == "1070") return RoofShape::Pyramid;
    return std::nullopt;
}

ExtrusionResult extrudeFootprint(const Footprint2d& footprint, const ExtrusionParams& params) {
    ExtrusionResult result;
    auto reject = [&](std::string_view why) {
        result.polygons.clear();
        result.fallback = "nothing built: ";
        result.fallback += why;
        return result;
    };
    const double base = params.base_z, eave = params.eave_z;
    if (!std::isfinite(base) || !std::isfinite(eave) || !std::isfinite(params.ridge_z))
        return reject("base_z, eave_z or ridge_z is not finite");
    if (!(eave > base)) return reject("eave_z <= base_z");
    for (const Vec2d& p : footprint.outer)
        if (!isFinite(p)) return reject("footprint has a non-finite coordinate");
    for (const auto& hole : footprint.holes)
        for (const Vec2d& p : hole)
            if (!isFinite(p)) return reject("footprint has a non-finite coordinate");

    // Working rings: duplicates dropped, orientation fixed, degenerate holes skipped.
    std::vector<Ring> rings;
    rings.push_back(makeRing(footprint.outer, 0));
    if (rings[0].size() < 3) return reject("footprint has fewer than 3 distinct points");
    double min_x = 1e300, min_y = 1e300, max_x = -1e300, max_y = -1e300;
    for (const Vec2d& p : rings[0].p) {
        min_x = std::min(min_x, p.x), min_y = std::min(min_y, p.y);
        max_x = std::max(max_x, p.x), max_y = std::max(max_y, p.y);
    }
    const double extent2 = (max_x - min_x) * (max_x - min_x) + (max_y - min_y) * (max_y - min_y);
    auto zeroArea = [&](double area) { return !(std::abs(area) > 1e-12 * extent2) || !(std::abs(area) > 0); };
    const double outer_area = signedArea(rings[0].p);
    if (zeroArea(outer_area)) return reject("footprint has zero area");
    if (outer_area < 0) reverseRing(rings[0]);
    std::string notes;
    for (size_t h = 0; h < footprint.holes.size(); ++h) {
        Ring hole = makeRing(footprint.holes[h], h + 1);
        const double area = hole.size() >= 3 ? signedArea(hole.p) : 0.0;
        if (hole.size() < 3 || zeroArea(area)) {
            addReason(notes, "ignored a degenerate hole");
            continue;
        }
        if (area > 0) reverseRing(hole);
        rings.push_back(std::move(hole));
    }

    // Roof.
    const double ridge = params.ridge_z;
    RoofShape want = params.roof;
    if (want != RoofShape::Flat && !(ridge > eave)) {
        addReason(notes, ridge < eave ? "ridge_z below eave_z; built flat"
                                      : "no roof height (ridge_z == eave_z); built flat");
        want = RoofShape::Flat;
    }
    std::optional<Roof> roof;
    if (want == RoofShape::Gable) {
        roof = gableRoof(rings, eave, ridge);
        if (!roof) {
            addReason(notes, rings.size() > 1 ? "gable needs a rectangle without holes; built hip"
                                              : "gable needs a rectangle; built hip");
            want = RoofShape::Hip;
        }
    } else if (want == RoofShape::Pyramid) {
        roof = pyramidRoof(rings, eave, ridge);
        if (!roof) {
            addReason(notes, rings.size() > 1 ? "pyramid needs a convex footprint without holes; built hip"
                                              : "pyramid needs a convex footprint; built hip");
            want = RoofShape::Hip;
        }
    }
    if (!roof && want == RoofShape::Hip) {
        roof = hipRoof(rings, eave, ridge);
        if (!roof) addReason(notes, "straight skeleton failed; built flat");
    }
    if (!roof && want == RoofShape::Shed) roof = shedRoof(rings, eave, ridge);
    if (!roof) roof = flatRoof(rings, eave);
    result.built = roof->shape;
    result.fallback = std::move(notes);

    // Walls: one per edge of every ring, from the (party-wall) bottom up to the roof edge above.
    const bool wall_uv = params.projection_width_m > 0 && std::isfinite(params.projection_width_m);
    const double inv_pw = wall_uv ? 1.0 / params.projection_width_m : 0.0;
    const double inv_wall_h = 1.0 / (eave - base);
    for (size_t r = 0; r < rings.size(); ++r) {
        const Ring& ring = rings[r];
        const size_t n = ring.size();
        std::vector<double> along(n + 1, 0.0);
        for (size_t k = 0; k < n; ++k) along[k + 1] = along[k] + len2(sub(ring.at(k + 1), ring.p[k]));
        for (size_t k = 0; k < n; ++k) {
            const Vec2d a = ring.p[k], b = ring.at(k + 1);
            double bottom = base;
            if (ring.input_ring < params.wall_bottom_z.size()) {
                const auto& per_edge = params.wall_bottom_z[ring.input_ring];
                const size_t e = ring.input_edge[k];
                if (e < per_edge.size() && std::isfinite(per_edge[e])) bottom = std::max(base, per_edge[e]);
            }
            std::vector<ProfilePoint> outline{{0, {a.x, a.y, base}}, {1, {b.x, b.y, base}},
                                              {1, {b.x, b.y, roof->vertex_z[r][(k + 1) % n]}}};
            const auto& extra = roof->edge_extra[r][k];
            for (auto it = extra.rbegin(); it != extra.rend(); ++it) outline.push_back(*it);
            outline.push_back({0, {a.x, a.y, roof->vertex_z[r][k]}});
            double top = -1e300;
            for (size_t i = 2; i < outline.size(); ++i) top = std::max(top, outline[i].p.z);
            if (bottom >= top) {
                result.walls_removed++;
                continue;
            }
            if (bottom > base) outline = clipAbove(outline, bottom, a, b);
            std::vector<ProfilePoint> clean;
            for (const ProfilePoint& q : outline)
                if (clean.empty() || !(clean.back().p == q.p)) clean.push_back(q);
            while (clean.size() > 1 && clean.back().p == clean.front().p) clean.pop_back();
            if (clean.size() < 3) {
                result.walls_removed++;
                continue;
            }
            ExtrudedPolygon wall;
            wall.semantic = SurfaceSemantic::Wall;
            std::vector<Vec3d> pts;
            std::vector<Vec2d> uv;
            for (const ProfilePoint& q : clean) {
                pts.push_back(q.p);
                if (wall_uv) {
                    const double s = q.lam <= 0   ? along[k]
                                     : q.lam >= 1 ? along[k + 1]
                                                  : along[k] + q.lam * (along[k + 1] - along[k]);
                    uv.push_back({s * inv_pw, (q.p.z - base) * inv_wall_h});
                }
            }
            wall.rings.push_back(std::move(pts));
            if (wall_uv) wall.uv.push_back(std::move(uv));
            result.polygons.push_back(std::move(wall));
        }
    }

    // Roof polygons.
    const bool roof_uv = params.roof_texture_size_m > 0 && std::isfinite(params.roof_texture_size_m);
    const double inv_size = roof_uv ? 1.0 / params.roof_texture_size_m : 0.0;
    for (auto& face : roof->faces) {
        ExtrudedPolygon poly;
        poly.semantic = SurfaceSemantic::Roof;
        if (roof_uv)
            for (const auto& ring : face) {
                std::vector<Vec2d> uv;
                for (const Vec3d& p : ring) uv.push_back({(p.x - min_x) * inv_size, (p.y - min_y) * inv_size});
                poly.uv.push_back(std::move(uv));
            }
        poly.rings = std::move(face);
        result.polygons.push_back(std::move(poly));
    }
    return result;
}

}  // namespace cityatlas::footprints
