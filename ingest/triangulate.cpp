// SPDX-License-Identifier: GPL-3.0-or-later
// CGAL is header-only and slow to compile (~25 s a TU): keep it in this file.
#include "ingest/triangulate.h"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <cmath>
#include <deque>
#include <limits>

namespace cityatlas {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
struct FaceInfo {
    int nesting_level = -1;  // -1: not yet visited
    bool inside() const { return nesting_level % 2 == 1; }
};
// Vertices CGAL creates itself (at constraint crossings) keep kAdded.
constexpr uint32_t kAdded = UINT32_MAX;
struct VertexInfo {
    uint32_t index = kAdded;
};
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<VertexInfo, Kernel>;
using FaceBaseInfo = CGAL::Triangulation_face_base_with_info_2<FaceInfo, Kernel>;
using FaceBase = CGAL::Constrained_triangulation_face_base_2<Kernel, FaceBaseInfo>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds, CGAL::Exact_predicates_tag>;

// Flood fill from the infinite face: each crossing of a constraint edge raises
// the nesting level by one; odd levels are inside the polygon. (CGAL 5.5 has
// no mark_domain_in_triangulation; this is the classic example algorithm.)
void markNestingLevels(Cdt& cdt) {
    std::deque<Cdt::Face_handle> border{cdt.infinite_face()};
    int level = 0;
    while (!border.empty()) {
        std::deque<Cdt::Face_handle> next_border;
        while (!border.empty()) {
            Cdt::Face_handle start = border.front();
            border.pop_front();
            if (start->info().nesting_level != -1) continue;
            std::deque<Cdt::Face_handle> queue{start};
            while (!queue.empty()) {
                Cdt::Face_handle f = queue.front();
                queue.pop_front();
                if (f->info().nesting_level != -1) continue;
                f->info().nesting_level = level;
                for (int i = 0; i < 3; ++i) {
                    Cdt::Face_handle n = f->neighbor(i);
                    if (n->info().nesting_level != -1) continue;
                    if (cdt.is_constrained(Cdt::Edge(f, i)))
                        next_border.push_back(n);
                    else
                        queue.push_back(n);
                }
            }
        }
        border.swap(next_border);
        ++level;
    }
}

}  // namespace

Vec3d newellNormal(std::span<const Vec3d> ring) {
    // Relative to the first vertex: the cross terms then stay small and exact
    // for rings far from the local origin.
    Vec3d n;
    if (ring.empty()) return n;
    const Vec3d o = ring[0];
    for (size_t i = 0; i < ring.size(); ++i) {
        Vec3d a = ring[i] - o;
        Vec3d b = ring[(i + 1) % ring.size()] - o;
        n.x += (a.y - b.y) * (a.z + b.z);
        n.y += (a.z - b.z) * (a.x + b.x);
        n.z += (a.x - b.x) * (a.y + b.y);
    }
    return n;
}

double polygonArea(const PolygonRings& polygon) {
    if (polygon.rings.empty()) return 0;
    double area = 0.5 * length(newellNormal(polygon.rings[0]));
    for (size_t r = 1; r < polygon.rings.size(); ++r) area -= 0.5 * length(newellNormal(polygon.rings[r]));
    return area;
}

PolygonTriangulation triangulatePolygon(const PolygonRings& polygon) {
    PolygonTriangulation result;
    if (polygon.rings.empty() || polygon.rings[0].size() < 3) {
        result.degenerate = true;
        return result;
    }
    const Vec3d n = newellNormal(polygon.rings[0]);
    const double n_len = length(n);
    if (!(n_len > 0) || !std::isfinite(n_len)) {
        result.degenerate = true;
        return result;
    }
    const Vec3d normal = (1.0 / n_len) * n;
    result.unit_normal = normal;

    // Orthonormal basis (e1, e2) of the plane with e1 x e2 = normal, so that
    // counter-clockwise in 2D is counter-clockwise seen from the front in 3D.
    const Vec3d helper = std::abs(normal.x) < 0.9 ? Vec3d{1, 0, 0} : Vec3d{0, 1, 0};
    Vec3d e1 = cross(helper, normal);
    e1 = (1.0 / length(e1)) * e1;
    const Vec3d e2 = cross(normal, e1);
    const Vec3d origin = polygon.rings[0][0];

    // Plane through the centroid of the exterior ring, for the deviation figure.
    Vec3d centroid;
    for (const Vec3d& p : polygon.rings[0]) centroid = centroid + (p - origin);
    centroid = (1.0 / static_cast<double>(polygon.rings[0].size())) * centroid;

    Cdt cdt;
    uint32_t index = 0;
    for (std::span<const Vec3d> ring : polygon.rings) {
        std::vector<Cdt::Vertex_handle> handles;
        handles.reserve(ring.size());
        for (const Vec3d& p : ring) {
            const Vec3d d = p - origin;
            result.max_plane_deviation_m =
                std::max(result.max_plane_deviation_m, std::abs(dot(d - centroid, normal)));
            const size_t before = cdt.number_of_vertices();
            Cdt::Vertex_handle v = cdt.insert(Kernel::Point_2(dot(d, e1), dot(d, e2)));
            // A point that repeats an earlier one (in 2D) keeps the first index.
            if (cdt.number_of_vertices() > before) v->info().index = index;
            else if (handles.empty() || handles.back() != v) result.repeated_vertices++;
            handles.push_back(v);
            ++index;
        }
        for (size_t i = 0; i < handles.size(); ++i) {
            auto a = handles[i], b = handles[(i + 1) % handles.size()];
            if (a != b) cdt.insert_constraint(a, b);
        }
    }
    // The ring closing onto its first point is not a repeat.
    for (std::span<const Vec3d> ring : polygon.rings)
        if (ring.size() > 1 && ring.front() == ring.back() && result.repeated_vertices > 0) result.repeated_vertices--;

    // Points CGAL added at crossings: lift onto the plane, and fit an affine
    // (u, v) = a + b x + c y to the input's texture coordinates for them.
    const double plane_offset = dot(centroid, normal);
    std::array<double, 3> fit_u{}, fit_v{};
    bool have_fit = false;
    auto fitAffine = [&]() {
        // Normal equations of the least-squares fit over all input vertices.
        double m[3][3] = {}, ru[3] = {}, rv[3] = {};
        for (size_t r = 0; r < polygon.uv.size() && r < polygon.rings.size(); ++r)
            for (size_t i = 0; i < polygon.rings[r].size() && i < polygon.uv[r].size(); ++i) {
                const Vec3d d = polygon.rings[r][i] - origin;
                const double row[3] = {1.0, dot(d, e1), dot(d, e2)};
                for (int a = 0; a < 3; ++a) {
                    for (int b = 0; b < 3; ++b) m[a][b] += row[a] * row[b];
                    ru[a] += row[a] * polygon.uv[r][i].x;
                    rv[a] += row[a] * polygon.uv[r][i].y;
                }
            }
        // Cramer's rule on the 3x3 system.
        auto det3 = [](double a[3][3]) {
            return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                   a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
        };
        const double det = det3(m);
        if (!(std::abs(det) > 1e-12)) return false;
        for (int k = 0; k < 3; ++k) {
            double mu[3][3], mv[3][3];
            for (int a = 0; a < 3; ++a)
                for (int b = 0; b < 3; ++b) mu[a][b] = mv[a][b] = m[a][b];
            for (int a = 0; a < 3; ++a) mu[a][k] = ru[a], mv[a][k] = rv[a];
            fit_u[k] = det3(mu) / det;
            fit_v[k] = det3(mv) / det;
        }
        return true;
    };
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
        if (v->info().index != kAdded) continue;
        const double x = v->point().x(), y = v->point().y();
        v->info().index = index + static_cast<uint32_t>(result.added_points.size());
        result.added_points.push_back(origin + x * e1 + y * e2 + plane_offset * normal);
        if (!polygon.uv.empty() && !have_fit) have_fit = fitAffine();
        result.added_uv.push_back(have_fit ? Vec2d{fit_u[0] + fit_u[1] * x + fit_u[2] * y,
                                                   fit_v[0] + fit_v[1] * x + fit_v[2] * y}
                                           : Vec2d{});
    }

    markNestingLevels(cdt);
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
        if (!f->info().inside()) continue;
        result.triangles.push_back(
            {f->vertex(0)->info().index, f->vertex(1)->info().index, f->vertex(2)->info().index});
    }
    if (result.triangles.empty()) result.degenerate = true;
    return result;
}

}  // namespace cityatlas
