// SPDX-License-Identifier: GPL-3.0-or-later
// The switching-distance test of issue 20 (../shared/SEED-FEATURES.md §1.3):
// for the root and each level-1 node of a town, a BlockMap whose cell is the
// node's world texel, seen from exactly the node's switching distance (a
// cell covers at most a pixel anywhere on the screen, frustum corners
// included), against a supersampled render of the node's full-detail
// triangles: 48 cameras around the node, half with it at the image centre
// and half near a corner.
//
// Both are traced on the CPU: the BlockMap with the C++ traversal, one ray
// through each pixel centre as the fragment shader does (the shader equals
// that traversal pixel for pixel: test_blockmap_gl); the full detail with
// Embree (atlas/raycast.h), 4 x 4 rays a pixel, a pixel covered when half of
// them hit, its building the most frequent. The metrics and bars are the
// spec's (§1.3 "Render-level", item 4):
//  (i)  the symmetric Hausdorff distance between the two masks (the covered
//       pixels) <= 1.5 px in every view;
//  (ii) on the pixels both cover, ids agree on >= 97 % of them (over a
//       node's 48 views), and every disagreeing pixel is within 1.5 px of
//       an id edge of the reference;
//  (v)  at half the distance (i) fails for at least one view.
// The masks are traced kMargin pixels beyond the frame, so a pixel on the
// border is matched to the other mask as the scene has it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <vector>


#include "atlas/blockmap.h"
#include "atlas/raycast.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "render/core/blockmap_ray.h"
#include "render/core/view.h"

namespace cityatlas::render {
namespace {

constexpr int kWidth = 192, kHeight = 144;
constexpr double kFovDeg = 60;
constexpr uint32_t kNone = 0xFFFFFFFFu;

Vec3d normalize(const Vec3d& v) { return (1.0 / length(v)) * v; }

struct View {
    Vec3d eye, forward, right, up;
    double focal = 0;
    Vec3d ray(double px, double py) const {  // px, py: pixel coordinates, y down
        return normalize(focal * forward + (px - kWidth / 2.0) * right + (kHeight / 2.0 - py) * up);
    }
};

View lookAt(const Vec3d& eye, const Vec3d& target, double focal) {
    View v;
    v.eye = eye;
    v.focal = focal;
    v.forward = normalize(target - eye);
    v.right = normalize(cross(v.forward, Vec3d{0, 0, 1}));
    v.up = cross(v.right, v.forward);
    return v;
}

// A frame and kMargin pixels around it: a mask's distance is to the other
// mask as the scene has it, not as the frame's border clips it (a pixel on
// the border whose match lies just outside would otherwise count as far).
constexpr int kMargin = 4;
struct Image {
    std::vector<uint32_t> ids = std::vector<uint32_t>((kWidth + 2 * kMargin) * (kHeight + 2 * kMargin), kNone);
    static bool stored(int x, int y) { return x >= -kMargin && y >= -kMargin && x < kWidth + kMargin && y < kHeight + kMargin; }
    uint32_t& id(int x, int y) { return ids[static_cast<size_t>((y + kMargin) * (kWidth + 2 * kMargin) + x + kMargin)]; }
    uint32_t id(int x, int y) const { return stored(x, y) ? ids[static_cast<size_t>((y + kMargin) * (kWidth + 2 * kMargin) + x + kMargin)] : kNone; }
    bool covered(int x, int y) const { return id(x, y) != kNone; }
};

struct Comparison {
    double hausdorff_px = 0;       ///< between the masks
    size_t both = 0, agree = 0;    ///< pixels both cover; of those, with the same building
    size_t off_edge = 0;           ///< disagreeing pixels farther than 1.5 px from an id edge of the reference
};

// The farthest covered pixel of `a` in the frame from the covered pixels of
// `b` in the frame and its margin (a square window first, everything when it
// holds none); 1e9 when `b` covers nothing and `a` something.
double directed(const Image& a, const Image& b) {
    constexpr int kWindow = 8;
    double worst = 0;
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x) {
            if (!a.covered(x, y)) continue;
            double best = 1e18;
            const auto search = [&](int r) {
                for (int yy = y - r; yy <= y + r; ++yy)
                    for (int xx = x - r; xx <= x + r; ++xx)
                        if (b.covered(xx, yy)) best = std::min(best, double((xx - x) * (xx - x) + (yy - y) * (yy - y)));
            };
            search(kWindow);
            if (best > kWindow * kWindow) search(std::max(kWidth, kHeight) + kMargin);  // the nearest lies farther
            worst = std::max(worst, best >= 1e18 ? 1e9 : std::sqrt(best));
        }
    return worst;
}

// An id edge of `im`: a covered pixel with a 4-neighbour of another building
// or uncovered.
bool idEdge(const Image& im, int x, int y) {
    const uint32_t id = im.id(x, y);
    return id != kNone && (im.id(x - 1, y) != id || im.id(x + 1, y) != id || im.id(x, y - 1) != id || im.id(x, y + 1) != id);
}

// The masks and ids over the frame.
Comparison compare(const Image& reference, const Image& test) {
    Comparison c;
    c.hausdorff_px = std::max(directed(reference, test), directed(test, reference));
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x) {
            if (!reference.covered(x, y) || !test.covered(x, y)) continue;
            ++c.both;
            if (reference.id(x, y) == test.id(x, y)) {
                ++c.agree;
                continue;
            }
            // Within 1.5 px: the pixel or one of its 8 neighbours is an id edge.
            bool near = false;
            for (int dy = -1; dy <= 1 && !near; ++dy)
                for (int dx = -1; dx <= 1 && !near; ++dx) near = idEdge(reference, x + dx, y + dy);
            c.off_edge += !near;
        }
    return c;
}

// A node of the tree: its buildings' triangles whole, its BlockMap at its
// texel, the full detail as Embree's scene.
struct Node {
    const char* name = "";
    std::vector<Triangle> triangles;
    Box3d box;
    double cell = 0;
    std::unique_ptr<atlas::RayCaster> caster;
    format::BlockMap bm;
};

class BlockMapSwitching : public ::testing::Test {
protected:
    // The root (every building, cells of kCell) and the four level-1 nodes
    // (the buildings whose box centre lies in a quadrant of the town's box,
    // cells of kCell / 2: a child's texel is half its parent's).
    static void SetUpTestSuite() {
        synth::TownSettings s;
        s.buildings = 150;
        s.seed = 3;
        s.lod = 2;
        s.texture_size_px = 16;
        const synth::Town town = synth::generateTown(s);
        const Scene scene = synth::townToScene(town, "/nonexistent");
        Box3d town_box;
        std::map<uint32_t, Box3d> building_box;
        for (const Triangle& t : scene.triangles)
            for (const Vec3d& p : t.position_local) town_box.extend(p), building_box[t.feature].extend(p);
        const Vec3d mid = 0.5 * (town_box.min + town_box.max);
        static const char* kNames[] = {"root", "level 1, south-west", "level 1, south-east", "level 1, north-west",
                                       "level 1, north-east"};
        nodes_ = new std::vector<Node>(5);
        for (int k = 0; k < 5; ++k) {
            Node& n = (*nodes_)[static_cast<size_t>(k)];
            n.name = kNames[k];
            n.cell = k == 0 ? kCell : kCell / 2;
            for (const Triangle& t : scene.triangles) {
                const Box3d& b = building_box[t.feature];
                const int quadrant = (0.5 * (b.min.x + b.max.x) >= mid.x ? 1 : 0) + (0.5 * (b.min.y + b.max.y) >= mid.y ? 2 : 0);
                if (k == 0 || quadrant == k - 1) n.triangles.push_back(t);
            }
            ASSERT_FALSE(n.triangles.empty()) << n.name;
            std::vector<std::array<Vec3d, 3>> corners;
            for (const Triangle& t : n.triangles) {
                corners.push_back(t.position_local);
                for (const Vec3d& p : t.position_local) n.box.extend(p);
            }
            n.caster = atlas::RayCaster::build(corners);
            atlas::BlockMapParams p;
            p.cell_m = n.cell;
            ASSERT_TRUE(atlas::buildBlockMap(n.triangles, p, &n.bm).ok()) << n.name;
        }
        // The screen's focal length and corner factor as the atlas tree
        // defines them (atlas/atlas_tree.h ProjectionBound): a world texel s
        // covers at most a pixel anywhere from s * focal * corner on.
        focal_ = (kHeight / 2.0) / std::tan(kFovDeg * M_PI / 360.0);
        const double corner_tan = std::hypot(kWidth / 2.0, kHeight / 2.0) / focal_;
        corner_ = 1 + corner_tan * corner_tan;
    }
    static void TearDownTestSuite() { delete nodes_; }

    // The 48 views at `distance` from the node's box: 24 azimuths, three
    // elevations; even ones with the node's centre at the image centre, odd
    // ones with it turned towards a corner (at the root's distance the
    // town's own near corner sits about 10 px in from the image's).
    static std::vector<View> views(const Box3d& box, double distance) {
        std::vector<View> out;
        const Vec3d centre = 0.5 * (box.min + box.max);
        for (int k = 0; k < 48; ++k) {
            const double azimuth = (k % 24) * 15.0 * M_PI / 180 + (k >= 24 ? 7.5 * M_PI / 180 : 0);
            const double elevation = (20.0 + 15.0 * (k % 3)) * M_PI / 180;
            const Vec3d dir{std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                            std::sin(elevation)};
            // The eye on that ray at exactly `distance` from the box (bisection).
            double lo = 0, hi = distance + length(box.max - box.min);
            for (int i = 0; i < 100; ++i) {
                const double mid = 0.5 * (lo + hi);
                (distanceToBox(centre + mid * dir, box) < distance ? lo : hi) = mid;
            }
            const Vec3d eye = centre + hi * dir;
            View v = lookAt(eye, centre, focal_);
            if (k % 2) {
                // Turn the view so the centre appears towards the top-right corner.
                const double ox = 0.25 * kWidth, oy = 0.2 * kHeight;
                v = lookAt(eye, eye + (focal_ * v.forward - ox * v.right + oy * v.up), focal_);
            }
            out.push_back(v);
        }
        return out;
    }

    // Each pixel from n x n rays: covered when at least half hit, its
    // building the most frequent among the hits.
    template <class Trace>
    static Image sampled(const View& v, int n, const Trace& trace) {
        Image im;
        for (int y = -kMargin; y < kHeight + kMargin; ++y)
            for (int x = -kMargin; x < kWidth + kMargin; ++x) {
                std::map<uint32_t, int> votes;
                int hits = 0;
                for (int a = 0; a < n; ++a)
                    for (int b = 0; b < n; ++b) {
                        const uint32_t f = trace(v.eye, v.ray(x + (a + 0.5) / n, y + (b + 0.5) / n));
                        if (f == kNone) continue;
                        ++hits;
                        ++votes[f];
                    }
                if (2 * hits < n * n) continue;
                im.id(x, y) =
                    std::max_element(votes.begin(), votes.end(), [](auto& p, auto& q) { return p.second < q.second; })->first;
            }
        return im;
    }

    // The 48 views of a node at `factor` x its switching distance: the
    // BlockMap (one ray a pixel, as the shader) and, for comparison, the
    // full detail drawn the same way, each against the supersampled full
    // detail.
    struct Figures {
        double worst_px = 0;       // (i): the worst view's mask Hausdorff
        size_t both = 0, agree = 0, off_edge = 0;  // (ii), summed over the views
        double worst_view_ids = 1;  // the lowest agreement of one view (reported)
        void add(const Comparison& c) {
            worst_px = std::max(worst_px, c.hausdorff_px);
            both += c.both, agree += c.agree, off_edge += c.off_edge;
            if (c.both) worst_view_ids = std::min(worst_view_ids, double(c.agree) / double(c.both));
        }
        double ids() const { return both ? double(agree) / double(both) : 1; }
        bool withinBar() const { return worst_px <= 1.5 && ids() >= 0.97 && off_edge == 0; }
    };
    struct Run {
        Figures blockmap, geometry;
    };
    static Run run(const Node& n, double factor) {
        const auto geometry = [&](const Vec3d& eye, const Vec3d& dir) {
            const atlas::RayHit h = n.caster->nearest(eye, dir);
            return h.hit ? n.triangles[h.triangle].feature : kNone;
        };
        const auto blockmap = [&](const Vec3d& eye, const Vec3d& dir) {
            const BlockMapHit h = castBlockMapRay(n.bm, eye, dir);
            return h.hit ? n.bm.features[n.bm.cells[n.bm.index(h.x, h.y)].feature] : kNone;
        };
        Run r;
        for (const View& v : views(n.box, factor * n.cell * focal_ * corner_)) {
            const Image ref = sampled(v, 4, geometry);
            r.blockmap.add(compare(ref, sampled(v, 1, blockmap)));
            r.geometry.add(compare(ref, sampled(v, 1, geometry)));
        }
        const auto print = [](const char* what, const Figures& f) {
            std::printf("  %s: masks within %.2f px (worst view); ids agree on %.2f %% of %zu pixels both cover "
                        "(worst view %.2f %%), %zu disagreeing farther than 1.5 px from an id edge\n",
                        what, f.worst_px, 100 * f.ids(), f.both, 100 * f.worst_view_ids, f.off_edge);
        };
        std::printf("%s, %.1f x its switching distance (cell %.2f m, %d x %d cells), 48 views against the "
                    "supersampled full detail:\n", n.name, factor, n.cell, n.bm.nx, n.bm.ny);
        print("BlockMap", r.blockmap);
        print("full detail, one sample a pixel", r.geometry);
        return r;
    }

    static constexpr double kCell = 2.5;
    static std::vector<Node>* nodes_;
    static double focal_, corner_;
};
std::vector<Node>* BlockMapSwitching::nodes_ = nullptr;
double BlockMapSwitching::focal_ = 0, BlockMapSwitching::corner_ = 1;

// Measured (this test's output): at 1x the root's masks are within 1.41 px
// and its ids agree on 98.2 % of 70,836 pixels (the worst view 94.9 %: at
// 20 degrees, the town under 1,000 px), the level-1 nodes' within 1.00 px
// and 99.1-99.4 %, every disagreement at an id edge. At 0.5x the root's
// masks are 2.00 px apart, the level-1 nodes' 1.41 px (half a 2-px cell's
// diagonal: only the root misses there). Conservative cells
// (BlockMapSample::Max) pass too (1.41 px, 97.1 % at the root). Mutation:
// every cell sampled one cell to the side fails it (2.24 px, 95.7 %).
TEST_F(BlockMapSwitching, AtTheSwitchingDistanceItLooksAsTheFullDetailDoes) {
    for (const Node& n : *nodes_) {
        const Run r = run(n, 1.0);
        EXPECT_LE(r.blockmap.worst_px, 1.5) << n.name;
        EXPECT_GE(r.blockmap.ids(), 0.97) << n.name;
        EXPECT_EQ(r.blockmap.off_edge, 0u) << n.name;
        EXPECT_TRUE(r.blockmap.withinBar()) << n.name;
    }
}

// The spec's non-vacuity check (v): the same test at half the distance
// fails, (i) missed by at least one view.
TEST_F(BlockMapSwitching, AtHalfTheDistanceTheBarIsMissed) {
    double worst_px = 0;
    for (const Node& n : *nodes_) worst_px = std::max(worst_px, run(n, 0.5).blockmap.worst_px);
    EXPECT_GT(worst_px, 1.5);
}

}  // namespace
}  // namespace cityatlas::render
