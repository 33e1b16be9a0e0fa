// SPDX-License-Identifier: GPL-3.0-or-later
// The switching-distance test of issue 20 (../shared/SEED-FEATURES.md §1.3):
// a BlockMap whose cell is the node's world texel, seen from exactly the
// node's switching distance (a cell covers at most a pixel anywhere on the
// screen, frustum corners included), against a supersampled render of the
// full-detail triangles: 48 cameras around the town, half with the town at
// the image centre and half near a corner.
//
// Both are traced on the CPU: the BlockMap with the C++ traversal, one ray
// through each pixel centre as the fragment shader does (the shader equals
// that traversal pixel for pixel: test_blockmap_gl); the full detail with
// Embree (atlas/raycast.h), 4 x 4 rays a pixel, a pixel covered when half of
// them hit, its building the most frequent. The metrics and bars are the
// spec's (§1.3 "Render-level", item 4):
//  (i)  the symmetric Hausdorff distance between the two masks (the covered
//       pixels) <= 1.5 px in every view;
//  (ii) on the pixels both cover, ids agree on >= 97 % of them (over the 48
//       views), and every disagreeing pixel is within 1.5 px of an id edge
//       of the reference;
//  (v)  at half the distance (i) fails for at least one view.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
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

struct Image {
    std::vector<uint32_t> id = std::vector<uint32_t>(kWidth * kHeight, kNone);
    bool covered(int x, int y) const { return id[static_cast<size_t>(y * kWidth + x)] != kNone; }
};

struct Comparison {
    double hausdorff_px = 0;       ///< between the masks
    size_t both = 0, agree = 0;    ///< pixels both cover; of those, with the same building
    size_t off_edge = 0;           ///< disagreeing pixels farther than 1.5 px from an id edge of the reference
};

// The farthest covered pixel of `a` from the covered pixels of `b` (a square
// window first, the whole image when it holds none); 1e9 when `b` covers
// nothing and `a` something.
double directed(const Image& a, const Image& b) {
    constexpr int kWindow = 8;
    double worst = 0;
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x) {
            if (!a.covered(x, y)) continue;
            double best = 1e18;
            const auto search = [&](int r) {
                for (int yy = std::max(0, y - r); yy <= std::min(kHeight - 1, y + r); ++yy)
                    for (int xx = std::max(0, x - r); xx <= std::min(kWidth - 1, x + r); ++xx)
                        if (b.covered(xx, yy)) best = std::min(best, double((xx - x) * (xx - x) + (yy - y) * (yy - y)));
            };
            search(kWindow);
            if (best > kWindow * kWindow) search(std::max(kWidth, kHeight));  // nearest may lie outside the window
            worst = std::max(worst, best >= 1e18 ? 1e9 : std::sqrt(best));
        }
    return worst;
}

// An id edge of `im`: a covered pixel with a 4-neighbour of another building
// or uncovered (or off the image).
bool idEdge(const Image& im, int x, int y) {
    const uint32_t id = im.id[static_cast<size_t>(y * kWidth + x)];
    const auto other = [&](int xx, int yy) {
        return xx < 0 || yy < 0 || xx >= kWidth || yy >= kHeight || im.id[static_cast<size_t>(yy * kWidth + xx)] != id;
    };
    return id != kNone && (other(x - 1, y) || other(x + 1, y) || other(x, y - 1) || other(x, y + 1));
}

Comparison compare(const Image& reference, const Image& test) {
    Comparison c;
    c.hausdorff_px = std::max(directed(reference, test), directed(test, reference));
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x) {
            const size_t i = static_cast<size_t>(y * kWidth + x);
            if (reference.id[i] == kNone || test.id[i] == kNone) continue;
            ++c.both;
            if (reference.id[i] == test.id[i]) {
                ++c.agree;
                continue;
            }
            // Within 1.5 px: the pixel or one of its 8 neighbours is an id edge.
            bool near = false;
            for (int dy = -1; dy <= 1 && !near; ++dy)
                for (int dx = -1; dx <= 1 && !near; ++dx) {
                    const int xx = x + dx, yy = y + dy;
                    near = xx >= 0 && yy >= 0 && xx < kWidth && yy < kHeight && idEdge(reference, xx, yy);
                }
            c.off_edge += !near;
        }
    return c;
}

class BlockMapSwitching : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        synth::TownSettings s;
        s.buildings = 150;
        s.seed = 3;
        s.lod = 2;
        s.texture_size_px = 16;
        const synth::Town town = synth::generateTown(s);
        scene_ = new Scene(synth::townToScene(town, "/nonexistent"));
        std::vector<std::array<Vec3d, 3>> corners;
        for (const Triangle& t : scene_->triangles) {
            corners.push_back(t.position_local);
            for (const Vec3d& p : t.position_local) box_.extend(p);
        }
        caster_ = atlas::RayCaster::build(corners).release();
        // The screen's focal length and corner factor as the atlas tree
        // defines them (atlas/atlas_tree.h ProjectionBound): a world texel s
        // covers at most a pixel anywhere from s * focal * corner on.
        focal_ = (kHeight / 2.0) / std::tan(kFovDeg * M_PI / 360.0);
        const double corner_tan = std::hypot(kWidth / 2.0, kHeight / 2.0) / focal_;
        corner_ = 1 + corner_tan * corner_tan;
        bm_ = new format::BlockMap;
        atlas::BlockMapParams p;
        p.cell_m = kCell;
        ASSERT_TRUE(atlas::buildBlockMap(scene_->triangles, p, bm_).ok());
    }
    static void TearDownTestSuite() {
        delete caster_;
        delete bm_;
        delete scene_;
    }

    // The 48 views at `distance` from the town's box: 24 azimuths, three
    // elevations; even ones with the town's centre at the image centre, odd
    // ones with it turned towards a corner (the town's own near corner sits
    // about 10 px in from the image's).
    static std::vector<View> views(double distance) {
        std::vector<View> out;
        const Vec3d centre = 0.5 * (box_.min + box_.max);
        for (int k = 0; k < 48; ++k) {
            const double azimuth = (k % 24) * 15.0 * M_PI / 180 + (k >= 24 ? 7.5 * M_PI / 180 : 0);
            const double elevation = (20.0 + 15.0 * (k % 3)) * M_PI / 180;
            const Vec3d dir{std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                            std::sin(elevation)};
            // The eye on that ray at exactly `distance` from the box (bisection).
            double lo = 0, hi = distance + length(box_.max - box_.min);
            for (int i = 0; i < 100; ++i) {
                const double mid = 0.5 * (lo + hi);
                (distanceToBox(centre + mid * dir, box_) < distance ? lo : hi) = mid;
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
        for (int y = 0; y < kHeight; ++y)
            for (int x = 0; x < kWidth; ++x) {
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
                im.id[static_cast<size_t>(y * kWidth + x)] =
                    std::max_element(votes.begin(), votes.end(), [](auto& p, auto& q) { return p.second < q.second; })->first;
            }
        return im;
    }
    static uint32_t geometry(const Vec3d& eye, const Vec3d& dir) {
        const atlas::RayHit h = caster_->nearest(eye, dir);
        return h.hit ? scene_->triangles[h.triangle].feature : kNone;
    }
    static uint32_t blockmap(const Vec3d& eye, const Vec3d& dir) {
        const BlockMapHit h = castBlockMapRay(*bm_, eye, dir);
        return h.hit ? bm_->features[bm_->cells[bm_->index(h.x, h.y)].feature] : kNone;
    }
    static Image reference(const View& v) { return sampled(v, 4, geometry); }

    // The 48 views at `factor` x the switching distance: the BlockMap (one
    // ray a pixel, as the shader) and, for comparison, the full detail drawn
    // the same way, each against the supersampled full detail.
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
    static Run run(double factor) {
        Run r;
        for (const View& v : views(factor * kCell * focal_ * corner_)) {
            const Image ref = reference(v);
            r.blockmap.add(compare(ref, sampled(v, 1, blockmap)));
            r.geometry.add(compare(ref, sampled(v, 1, geometry)));
        }
        const auto print = [](const char* what, const Figures& f) {
            std::printf("  %s: masks within %.2f px (worst view); ids agree on %.2f %% of %zu pixels both cover "
                        "(worst view %.2f %%), %zu disagreeing farther than 1.5 px from an id edge\n",
                        what, f.worst_px, 100 * f.ids(), f.both, 100 * f.worst_view_ids, f.off_edge);
        };
        std::printf("%.1f x the switching distance (cell %.1f m, %d x %d cells), 48 views against the supersampled "
                    "full detail:\n", factor, kCell, bm_->nx, bm_->ny);
        print("BlockMap", r.blockmap);
        print("full detail, one sample a pixel", r.geometry);
        return r;
    }

    static constexpr double kCell = 2.5;
    static Scene* scene_;
    static Box3d box_;
    static atlas::RayCaster* caster_;
    static format::BlockMap* bm_;
    static double focal_, corner_;
};
Scene* BlockMapSwitching::scene_ = nullptr;
Box3d BlockMapSwitching::box_;
atlas::RayCaster* BlockMapSwitching::caster_ = nullptr;
format::BlockMap* BlockMapSwitching::bm_ = nullptr;
double BlockMapSwitching::focal_ = 0, BlockMapSwitching::corner_ = 1;

// Measured (this test's output): at 1x the BlockMap's masks are within
// 1.41 px and its ids agree on 98.2 % of 70,836 pixels (the worst view
// 94.9 %: a view at 20 degrees where the town covers under 1,000 px), every
// disagreement at an id edge; at 0.5x the masks are 9.43 px apart.
// Conservative cells (BlockMapSample::Max) miss the bar: 2.00 px (ids 97.1 %).
TEST_F(BlockMapSwitching, AtTheSwitchingDistanceItLooksAsTheFullDetailDoes) {
    const Run r = run(1.0);
    EXPECT_LE(r.blockmap.worst_px, 1.5);
    EXPECT_GE(r.blockmap.ids(), 0.97);
    EXPECT_EQ(r.blockmap.off_edge, 0u);
    EXPECT_TRUE(r.blockmap.withinBar());
}

TEST_F(BlockMapSwitching, AtHalfTheDistanceTheBarIsMissed) {
    const Run r = run(0.5);
    EXPECT_GT(r.blockmap.worst_px, 1.5);
    EXPECT_FALSE(r.blockmap.withinBar());
}

}  // namespace
}  // namespace cityatlas::render
