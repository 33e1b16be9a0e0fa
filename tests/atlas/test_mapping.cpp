// SPDX-License-Identifier: GPL-3.0-or-later
// Texture mapping through the whole atlas tree, checked on pixels. A synthetic
// town is built with images; for random points of textured triangles the
// atlas of the leaf and of every ancestor (read back from its PNG, found
// through the triangle's root-atlas coordinates) must show what the ORIGINAL
// texture shows at that point, prefiltered to that atlas's resolution. The
// reference comes from the original files and the triangles' original uv;
// the tree's coordinates only say where to look in the atlas and how large
// one of its texels is. Each comparison is repeated against a wrong
// reference to show the statistic and its tolerance would catch a mix-up.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "atlas/atlas_images.h"
#include "atlas/atlas_tree.h"
#include "ingest/synth/town.h"
#include "ingest/synth/write_town.h"
#include "tests/ingest/test_support.h"

namespace cityatlas::atlas {
namespace {

namespace fs = std::filesystem;
using Rgba = std::array<double, 4>;

// ---------------------------------------------------------------------------
// Images in linear light, premultiplied, rows bottom-up: y follows v, as in
// texture space and in atlas texel coordinates.

struct LinearImage {
    int w = 0, h = 0, channels = 0;
    std::vector<float> px;       // 4 per texel: premultiplied linear RGB, alpha
    std::vector<uint8_t> bytes;  // the file's 8-bit values, rows top-down as stored
    const float* at(int x, int y) const { return &px[(static_cast<size_t>(y) * w + x) * 4]; }
};

// Straight alpha exactly as stored: OpenImageIO premultiplies PNG alpha on
// read unless told not to, and both the textures and the alpha atlases store
// straight alpha.
bool readLinear(const fs::path& path, LinearImage* img, std::string* error) {
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path.string(), &config);
    if (!in) {
        *error = path.string() + ": " + OIIO::geterror();
        return false;
    }
    const OIIO::ImageSpec& spec = in->spec();
    img->w = spec.width, img->h = spec.height, img->channels = spec.nchannels;
    img->bytes.resize(static_cast<size_t>(img->w) * img->h * img->channels);
    if (!in->read_image(0, 0, 0, img->channels, OIIO::TypeDesc::UINT8, img->bytes.data())) {
        *error = path.string() + ": " + in->geterror();
        return false;
    }
    img->px.assign(static_cast<size_t>(img->w) * img->h * 4, 0.0f);
    for (int row = 0; row < img->h; ++row)
        for (int x = 0; x < img->w; ++x) {
            const uint8_t* s = &img->bytes[(static_cast<size_t>(row) * img->w + x) * img->channels];
            float* d = &img->px[(static_cast<size_t>(img->h - 1 - row) * img->w + x) * 4];
            const double a = img->channels == 4 ? s[3] / 255.0 : 1.0;
            for (int c = 0; c < 3; ++c)
                d[c] = static_cast<float>(linearFromSrgb(s[img->channels >= 3 ? c : 0] / 255.0) * a);
            d[3] = static_cast<float>(a);
        }
    return true;
}

// Exact box means of a periodic, piecewise-constant texture over any
// axis-aligned rectangle (texel units, y up), through a summed-area table of
// one period: the integral from the origin is bilinear inside each texel, and
// whole periods add whole-period sums.
class PeriodicBox {
public:
    explicit PeriodicBox(const LinearImage& img)
        : w_(img.w), h_(img.h), t_(static_cast<size_t>(w_ + 1) * (h_ + 1) * 4, 0.0) {
        for (int y = 1; y <= h_; ++y)
            for (int x = 1; x <= w_; ++x)
                for (int c = 0; c < 4; ++c)
                    t_[idx(x, y) + c] = img.at(x - 1, y - 1)[c] + t_[idx(x - 1, y) + c] + t_[idx(x, y - 1) + c] -
                                        t_[idx(x - 1, y - 1) + c];
    }

    Rgba mean(double x0, double x1, double y0, double y1) const {
        const Rgba a = integral(x1, y1), b = integral(x0, y1), c = integral(x1, y0), d = integral(x0, y0);
        const double area = (x1 - x0) * (y1 - y0);
        Rgba m{};
        for (int k = 0; k < 4; ++k) m[k] = (a[k] - b[k] - c[k] + d[k]) / area;
        return m;
    }

private:
    size_t idx(int x, int y) const { return (static_cast<size_t>(y) * (w_ + 1) + x) * 4; }

    // Inside one period: bilinear in the table (exact for constant texels).
    Rgba table(double x, double y) const {
        const int ix = std::min(static_cast<int>(x), w_ - 1), iy = std::min(static_cast<int>(y), h_ - 1);
        const double fx = x - ix, fy = y - iy;
        Rgba r{};
        for (int c = 0; c < 4; ++c)
            r[c] = (1 - fx) * (1 - fy) * t_[idx(ix, iy) + c] + fx * (1 - fy) * t_[idx(ix + 1, iy) + c] +
                   (1 - fx) * fy * t_[idx(ix, iy + 1) + c] + fx * fy * t_[idx(ix + 1, iy + 1) + c];
        return r;
    }

    Rgba integral(double x, double y) const {
        const double qx = std::floor(x / w_), qy = std::floor(y / h_);
        const double rx = std::clamp(x - qx * w_, 0.0, static_cast<double>(w_));
        const double ry = std::clamp(y - qy * h_, 0.0, static_cast<double>(h_));
        const Rgba all = table(w_, h_), right = table(w_, ry), top = table(rx, h_), part = table(rx, ry);
        Rgba r{};
        for (int c = 0; c < 4; ++c) r[c] = qx * qy * all[c] + qx * right[c] + qy * top[c] + part[c];
        return r;
    }

    int w_, h_;
    std::vector<double> t_;
};

// ---------------------------------------------------------------------------
// Small linear algebra and a portable random generator.

struct Mat2 {
    double a = 0, b = 0, c = 0, d = 0;  // [a b; c d]
    Vec2d apply(const Vec2d& v) const { return {a * v.x + b * v.y, c * v.x + d * v.y}; }
};
Vec2d sub2(const Vec2d& p, const Vec2d& q) { return {p.x - q.x, p.y - q.y}; }

// uv as an affine function of positions p (the map a triangle's three corners
// define), as the change of uv per unit of p; false when degenerate.
bool uvPerPosition(const std::array<Vec2d, 3>& p, const std::array<Vec2d, 3>& uv, Mat2* m) {
    const Vec2d p1 = sub2(p[1], p[0]), p2 = sub2(p[2], p[0]), t1 = sub2(uv[1], uv[0]), t2 = sub2(uv[2], uv[0]);
    const double det = p1.x * p2.y - p1.y * p2.x;
    const double scale = std::max({p1.x * p1.x + p1.y * p1.y, p2.x * p2.x + p2.y * p2.y});
    if (!(std::abs(det) > 1e-9 * scale)) return false;
    // [t1 t2] * inverse([p1 p2])
    const double ia = p2.y / det, ib = -p2.x / det, ic = -p1.y / det, id = p1.x / det;
    *m = {t1.x * ia + t2.x * ic, t1.x * ib + t2.x * id, t1.y * ia + t2.y * ic, t1.y * ib + t2.y * id};
    return true;
}

struct Rng {
    uint64_t s;
    uint64_t next() {
        uint64_t z = (s += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
    std::array<double, 3> barycentric() {
        double r1 = uniform(), r2 = uniform();
        if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
        return {1 - r1 - r2, r1, r2};
    }
};

template <typename T>
T mix3(const std::array<T, 3>& v, const std::array<double, 3>& b) {
    return {b[0] * v[0].x + b[1] * v[1].x + b[2] * v[2].x, b[0] * v[0].y + b[1] * v[1].y + b[2] * v[2].y};
}

struct Stats {
    size_t n = 0;
    double median = 0, p90 = 0, max = 0;
};
Stats statsOf(std::vector<double> v) {
    Stats s;
    s.n = v.size();
    if (v.empty()) return s;
    std::sort(v.begin(), v.end());
    s.median = v[v.size() / 2];
    s.p90 = v[std::min(v.size() - 1, static_cast<size_t>(0.9 * static_cast<double>(v.size())))];
    s.max = v.back();
    return s;
}

// ---------------------------------------------------------------------------
// The fixture: one town, one tree with images, shared by the tests.

// 512-texel atlases at d_min = 300 m give this 32-building town a tree of
// depth 3 (57 nodes): leaves at levels 2 and 3, so every leaf has at least two
// ancestors and some have three, the first level at which the 2x2 box mean
// can mix neighbouring regions (see marginTexels). At d_min = 300 m a leaf
// stores 7.4 texels per metre, 0.16x to 1.2x the facades' own resolution
// (256 px over 5.5 to 42 m of wall), so minification and a little
// magnification both occur. The request is above the d_min the critical-
// triangle rule would raise it to, so the tree is built at exactly 300 m.
constexpr int kAtlasSize = 512;
constexpr double kDMin = 300.0;
constexpr int kTexturePx = 256;

struct World {
    std::string error;
    synth::Town town;
    Scene scene;
    AtlasTree tree;
    fs::path out;
    std::vector<int32_t> leaf_of;       // per tree triangle
    std::vector<LinearImage> textures;  // per scene texture
    std::vector<std::unique_ptr<PeriodicBox>> boxes;
    std::map<std::string, LinearImage> atlases;  // by atlas_path, read on demand

    const LinearImage* atlas(const std::string& rel) {
        auto it = atlases.find(rel);
        if (it != atlases.end()) return &it->second;
        LinearImage img;
        std::string err;
        if (rel.empty() || !readLinear(out / rel, &img, &err)) return nullptr;
        return &atlases.emplace(rel, std::move(img)).first->second;
    }
};

class AtlasMapping : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        world_ = new World;
        World& w = *world_;
        synth::TownSettings settings;
        settings.buildings = 32;
        settings.seed = 20240611;
        settings.texture_size_px = kTexturePx;
        w.town = synth::generateTown(settings);
        const fs::path town_dir = test::scratchPath("atlas_mapping", "town");
        w.out = test::scratchPath("atlas_mapping", "tree");
        if (Status s = synth::writeTown(w.town, town_dir, false, nullptr); !s.ok()) {
            w.error = "writeTown: " + s.error;
            return;
        }
        w.scene = synth::townToScene(w.town, town_dir);
        AtlasParams params;
        params.atlas_size_px = kAtlasSize;
        params.d_min_m = kDMin;
        params.render_images = true;
        Diagnostics diagnostics;
        if (Status s = buildAtlasTree(w.scene, params, w.out, diagnostics, nullptr, &w.tree); !s.ok()) {
            w.error = "buildAtlasTree: " + s.error;
            return;
        }
        w.leaf_of.assign(w.tree.triangles.size(), -1);
        for (size_t id = 0; id < w.tree.nodes.size(); ++id) {
            const AtlasNode& n = w.tree.nodes[id];
            if (!n.leaf()) continue;
            for (const NodeLayer& l : n.layers)
                for (uint32_t i = l.range.first; i < l.range.first + l.range.count && i < w.leaf_of.size(); ++i)
                    w.leaf_of[i] = static_cast<int32_t>(id);
        }
        for (size_t t = 0; t < w.scene.textures.size(); ++t) {
            LinearImage img;
            if (!readLinear(w.scene.textures.path(t), &img, &w.error)) return;
            w.boxes.push_back(std::make_unique<PeriodicBox>(img));
            w.textures.push_back(std::move(img));
        }
    }
    static void TearDownTestSuite() {
        std::error_code ec;
        fs::remove_all(world_->out.parent_path(), ec);  // this process's scratch folder: town and tree
        delete world_;
        world_ = nullptr;
    }
    void SetUp() override {
        ASSERT_TRUE(world_->error.empty()) << world_->error;
        // Without ancestors above the leaves' parents the inner atlases would go untested.
        ASSERT_GE(world_->tree.stats.depth, 2) << "d_min too large for this town";
    }

    static World* world_;
};
World* AtlasMapping::world_ = nullptr;

// ---------------------------------------------------------------------------
// Looking up one point of one triangle in one node's atlas.

// atlas_tree.h: texel = root * A * 2^level - offset, per layer.
Vec2d texelsAt(const AtlasNode& n, Layer layer, const Vec2d& root, int a) {
    const NodeLayer& l = n.layers[static_cast<int>(layer)];
    const double s = std::ldexp(static_cast<double>(a), n.level);
    return {root.x * s - static_cast<double>(l.offset[0]), root.y * s - static_cast<double>(l.offset[1])};
}

// Root-atlas coordinates of a position in a leaf's atlas texels.
Vec2d rootFromLeafTexels(const AtlasNode& leaf, Layer layer, const Vec2d& q, int a) {
    const NodeLayer& l = leaf.layers[static_cast<int>(layer)];
    const double s = std::ldexp(1.0 / a, -leaf.level);
    return {(q.x + static_cast<double>(l.offset[0])) * s, (q.y + static_cast<double>(l.offset[1])) * s};
}

// The border a region keeps on its narrower side (texel_estimate.h: at most --border).
int regionBorder(const PackedRegion& r) { return std::min(r.border_u, r.border_v); }

// A tree triangle as node N sees it: corners in N's atlas texels, the affine
// map from those texels to the original uv, and its leaf region in N's texels.
struct View {
    std::array<Vec2d, 3> p;
    Mat2 uv_per_texel;
    Vec2d lo, hi;  // the leaf region's rectangle, border included
};

bool viewIn(const AtlasNode& n, const AtlasNode& leaf, const PackedRegion& r, const TreeTriangle& t, int a, View* v) {
    const Layer l = t.layer;
    for (int c = 0; c < 3; ++c) v->p[c] = texelsAt(n, l, t.atlas_uv[c], a);
    v->lo = texelsAt(n, l, rootFromLeafTexels(leaf, l, {static_cast<double>(r.x), static_cast<double>(r.y)}, a), a);
    v->hi = texelsAt(n, l, rootFromLeafTexels(leaf, l, {static_cast<double>(r.x + r.w), static_cast<double>(r.y + r.h)}, a),
                     a);
    return uvPerPosition(v->p, t.tri.uv, &v->uv_per_texel);
}

double distanceToEdge(const Vec2d& p, const View& v) {
    return std::min({p.x - v.lo.x, v.hi.x - p.x, p.y - v.lo.y, v.hi.y - p.y});
}

// The leaf region a triangle was packed into: the one of its texture whose
// rectangle holds all three corners.
const PackedRegion* leafRegion(const AtlasNode& leaf, const TreeTriangle& t, int a) {
    for (const PackedRegion& r : leaf.layers[static_cast<int>(t.layer)].regions) {
        if (r.texture != t.tri.texture) continue;
        bool inside = true;
        for (int c = 0; c < 3; ++c) {
            const Vec2d q = texelsAt(leaf, t.layer, t.atlas_uv[c], a);
            inside =
                inside && q.x >= r.x - 1e-6 && q.x <= r.x + r.w + 1e-6 && q.y >= r.y - 1e-6 && q.y <= r.y + r.h + 1e-6;
        }
        if (inside) return &r;
    }
    return nullptr;
}

Rgba atlasTexel(const LinearImage& img, int x, int y) {
    x = std::clamp(x, 0, img.w - 1), y = std::clamp(y, 0, img.h - 1);
    const float* s = img.at(x, y);
    return {s[0], s[1], s[2], s[3]};
}

struct Probe {
    Rgba atlas{}, ref{};  // premultiplied linear RGB, alpha
};

// Bilinear interpolation between the four atlas texel centres around p, and
// the same weights on the reference's values at those centres: the original
// texture's box mean over the footprint of one atlas texel centred there
// (mapped to texture space through the triangle's affine map, which is the
// whole region's). Interpolating both alike leaves only the prefilter kernel
// and the 8-bit files as differences.
Probe probe(const LinearImage& atlas, const PeriodicBox& tex, int tw, int th, const Vec2d& p, const Vec2d& uv,
            const Mat2& m) {
    const double fx0 = p.x - 0.5, fy0 = p.y - 0.5;
    const int ix = static_cast<int>(std::floor(fx0)), iy = static_cast<int>(std::floor(fy0));
    const double fx = fx0 - ix, fy = fy0 - iy;
    const double hu = 0.5 * (std::abs(m.a) + std::abs(m.b)) * tw, hv = 0.5 * (std::abs(m.c) + std::abs(m.d)) * th;
    Probe r;
    for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
            const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
            const Vec2d d = m.apply(sub2({ix + dx + 0.5, iy + dy + 0.5}, p));
            const double x = (uv.x + d.x) * tw, y = (uv.y + d.y) * th;
            const Rgba ref = tex.mean(x - hu, x + hu, y - hv, y + hv);
            const Rgba at = atlasTexel(atlas, ix + dx, iy + dy);
            for (int c = 0; c < 4; ++c) r.ref[c] += w * ref[c], r.atlas[c] += w * at[c];
        }
    return r;
}

// Mean absolute difference over R, G, B (premultiplied linear light).
double colourError(const Probe& p) {
    return (std::abs(p.atlas[0] - p.ref[0]) + std::abs(p.atlas[1] - p.ref[1]) + std::abs(p.atlas[2] - p.ref[2])) / 3.0;
}
double alphaError(const Probe& p) { return std::abs(p.atlas[3] - p.ref[3]); }

// Margin (in N's texels) a point needs from its region's edge for N's atlas
// to show only that region around it. At the leaf every point of a triangle
// is safe: border_px (8) texels of real texture surround the content (checked
// below). Each halving halves the border; regions sit on a 4-texel grid, so
// after one and two halvings region edges still fall between texels and
// nothing mixes. From the third on a 2x2 box can straddle an edge: the mixed
// band is then at most one coarse texel plus half the band of the level below
// (0.5, 1.25, 1.6, ... texels), always under 2. Bilinear sampling reads
// texels reaching 1.5 texels from p. Hence 1.5 texels up to two halvings and
// 3.5 from the third.
double marginTexels(int halvings) { return halvings <= 2 ? 1.5 : 3.5; }

// Regions whose content has shrunk to a few texels at a level show no texture
// detail there (and nearly all their points fall inside the margin anyway).
constexpr double kMinContentTexels = 4;

// Tolerances on the error statistics, linear light, per level. Atlas and
// reference share the interpolation, so what differs is (1) 8-bit sRGB
// storage: half a code step is at most 0.0045 in linear light (at white);
// (2) the prefilter: Lanczos-3 (then 2x2 box means) against an exact box.
// On smooth content both give the local mean; across a step edge of contrast
// C they differ by up to about C/4 within a texel of it, with Lanczos's
// ringing (about 0.1 C) up to 3 texels away. Facades are full of such edges
// (window frames, glazing bars, plate, digits; C up to 0.9), and at the leaf
// a quarter or more of the points lie within a texel or two of one. So the
// median is held to about two 8-bit steps, and the 90th percentile to what
// the kernels may differ by near an edge of moderate contrast. A wrong
// mapping (another texture, or the right one off by a quarter) gives medians
// of 0.035 and up and 90th percentiles of 0.3 and up (measured), far outside.
constexpr double kMedianTolerance = 0.01;
constexpr double kP90Tolerance = 0.05;
// Fewer points than this at a level make its percentiles too coarse to judge.
constexpr size_t kMinPointsPerLevel = 50;

// One point of one triangle seen in one node's atlas.
struct LevelSample {
    int halvings = 0;  // levels above the triangle's leaf
    int32_t node = -1;
    const LinearImage* atlas = nullptr;
    Vec2d p;   // in the node's atlas texels
    Vec2d uv;  // the same point in the original texture
    Mat2 uv_per_texel;
};
using SampleFn = std::function<void(const TreeTriangle&, const LevelSample&)>;

// Random points on every textured triangle of `layer`, each looked up from
// its leaf up to the root, skipping levels where the region has shrunk to a
// few texels and points inside the margin.
void forEachLevelSample(World& w, Layer layer, uint64_t seed, int points_per_triangle, const SampleFn& fn) {
    const int a = w.tree.params.atlas_size_px;
    Rng rng{seed};
    for (uint32_t i = 0; i < w.tree.triangles.size(); ++i) {
        const TreeTriangle& t = w.tree.triangles[i];
        if (t.layer != layer || t.tri.texture < 0) continue;
        ASSERT_GE(w.leaf_of[i], 0) << "triangle " << i << " is in no leaf's range";
        const AtlasNode& leaf = w.tree.nodes[w.leaf_of[i]];
        const PackedRegion* region = leafRegion(leaf, t, a);
        ASSERT_NE(region, nullptr) << "triangle " << i << " lies in no region of its texture in leaf " << w.leaf_of[i];
        const int border = regionBorder(*region);
        {
            View v;
            if (!viewIn(leaf, leaf, *region, t, a, &v)) continue;
            for (const Vec2d& q : v.p)
                EXPECT_GE(distanceToEdge(q, v), border - 1e-6)
                    << "triangle " << i << ": a corner is closer than the border to its region's edge";
        }
        for (int s = 0; s < points_per_triangle; ++s) {
            const auto bary = rng.barycentric();
            const Vec2d root = mix3(t.atlas_uv, bary);
            int halvings = 0;
            for (int32_t id = w.leaf_of[i]; id >= 0; id = w.tree.nodes[id].parent, ++halvings) {
                const AtlasNode& n = w.tree.nodes[id];
                if ((std::min(region->w, region->h) - 2.0 * border) * std::ldexp(1.0, -halvings) < kMinContentTexels)
                    break;
                View v;
                if (!viewIn(n, leaf, *region, t, a, &v)) break;
                LevelSample ls;
                ls.p = texelsAt(n, layer, root, a);
                if (distanceToEdge(ls.p, v) < marginTexels(halvings)) continue;
                const std::string& path = n.layers[static_cast<int>(layer)].atlas_path;
                ls.atlas = w.atlas(path);
                ASSERT_NE(ls.atlas, nullptr) << "node " << id << ": cannot read '" << path << "'";
                ASSERT_EQ(ls.atlas->w, n.layers[static_cast<int>(layer)].width);
                ASSERT_EQ(ls.atlas->h, n.layers[static_cast<int>(layer)].height);
                ASSERT_EQ(ls.atlas->channels, layer == Layer::Opaque ? 3 : 4) << path;
                ls.halvings = halvings, ls.node = id;
                ls.uv = mix3(t.tri.uv, bary);
                ls.uv_per_texel = v.uv_per_texel;
                fn(t, ls);
            }
        }
    }
}

Probe probeTexture(const World& w, int32_t texture, const LevelSample& s, Vec2d uv_shift = {}) {
    return probe(*s.atlas, *w.boxes[texture], w.textures[texture].w, w.textures[texture].h, s.p,
                 {s.uv.x + uv_shift.x, s.uv.y + uv_shift.y}, s.uv_per_texel);
}

// The next texture with the same channel count: another building's facade
// (or, for the roofs' paving, the first facade).
int32_t otherTexture(const Scene& scene, int32_t t) {
    const int n = static_cast<int>(scene.textures.size());
    for (int k = 1; k < n; ++k) {
        const int32_t c = (t + k) % n;
        if (scene.textures[c].channels == scene.textures[t].channels) return c;
    }
    return t;
}

// A quarter of the texture in both directions: moves the number plate off
// itself and windows off windows (a shift along u alone would line a
// 4-column window grid up with itself).
constexpr Vec2d kQuarterShift{0.25, 0.25};

void printStats(const char* what, int halvings, const Stats& s) {
    std::printf("  %-34s leaf+%d: n %5zu  median %.4f  p90 %.4f  max %.3f\n", what, halvings, s.n, s.median, s.p90,
                s.max);
}

// The statistic must pass for the right reference and fail, by a wide
// margin, for a wrong one.
void expectDiscriminates(const char* what, int halvings, const Stats& right, const Stats& wrong) {
    EXPECT_GT(wrong.p90, kP90Tolerance) << what << ", leaf+" << halvings;
    EXPECT_GT(wrong.p90, 5 * right.p90) << what << ", leaf+" << halvings;
}

// ---------------------------------------------------------------------------

TEST_F(AtlasMapping, ColourMatchesPrefilteredOriginalAtEveryLevel) {
    World& w = *world_;
    struct LevelErrors {
        std::vector<double> right, other_texture, shifted;
    };
    std::map<int, LevelErrors> by_halvings;
    forEachLevelSample(w, Layer::Opaque, 12345, 8, [&](const TreeTriangle& t, const LevelSample& s) {
        LevelErrors& e = by_halvings[s.halvings];
        e.right.push_back(colourError(probeTexture(w, t.tri.texture, s)));
        e.other_texture.push_back(colourError(probeTexture(w, otherTexture(w.scene, t.tri.texture), s)));
        e.shifted.push_back(colourError(probeTexture(w, t.tri.texture, s, kQuarterShift)));
    });
    if (HasFatalFailure()) return;
    // The leaf and at least two ancestors above it, each with enough points.
    for (int h = 0; h <= 2; ++h) ASSERT_GE(by_halvings[h].right.size(), 10 * kMinPointsPerLevel) << "leaf+" << h;
    std::printf("opaque colour error |atlas - reference|, linear light, mean over RGB:\n");
    for (const auto& [h, e] : by_halvings) {
        const Stats r = statsOf(e.right), o = statsOf(e.other_texture), sh = statsOf(e.shifted);
        printStats("right texture and uv", h, r);
        printStats("wrong: next building's texture", h, o);
        printStats("wrong: uv + (0.25, 0.25)", h, sh);
        if (r.n < kMinPointsPerLevel) continue;
        EXPECT_LE(r.median, kMedianTolerance) << "leaf+" << h;
        EXPECT_LE(r.p90, kP90Tolerance) << "leaf+" << h;
        EXPECT_GT(o.median, kMedianTolerance) << "leaf+" << h;
        EXPECT_GT(sh.median, kMedianTolerance) << "leaf+" << h;
        expectDiscriminates("next building's texture", h, r, o);
        expectDiscriminates("uv + (0.25, 0.25)", h, r, sh);
    }
}

// The number plate's pixels in a facade texture: exactly white (and opaque),
// a colour nothing else on a facade uses (facade_texture.h). Returned as a uv
// box (v up); empty when the texture has no plate.
struct UvBox {
    Vec2d lo{1e300, 1e300}, hi{-1e300, -1e300};
    bool empty() const { return lo.x > hi.x; }
    bool holdsPeriodic(const Vec2d& uv) const {
        const double u = uv.x - std::floor(uv.x), v = uv.y - std::floor(uv.y);
        return u >= lo.x && u <= hi.x && v >= lo.y && v <= hi.y;
    }
};
UvBox plateBox(const LinearImage& img) {
    UvBox b;
    for (int row = 0; row < img.h; ++row)
        for (int x = 0; x < img.w; ++x) {
            const uint8_t* s = &img.bytes[(static_cast<size_t>(row) * img.w + x) * img.channels];
            const bool white = s[0] == 255 && s[1] == 255 && s[2] == 255 && (img.channels < 4 || s[3] == 255);
            if (!white) continue;
            b.lo = {std::min(b.lo.x, static_cast<double>(x) / img.w), std::min(b.lo.y, 1.0 - (row + 1.0) / img.h)};
            b.hi = {std::max(b.hi.x, (x + 1.0) / img.w), std::max(b.hi.y, 1.0 - static_cast<double>(row) / img.h)};
        }
    return b;
}

// Every building's walls, in the leaf atlases, against every facade of the
// town at the same uv, on the number plate only: white with the building's
// digits in black, so another facade differs there in its digits (and, for
// numbers of another length, in the plate's width), while the building's own
// texture must agree up to the prefilter. The comparison runs for every
// building: in this town every wall ring is longer than its building's
// eave height (the width of one facade texture), so each building shows its
// plate at least once, and at this d_min one font cell of the digits (8 px
// of a 256 px facade) spans 1.3 to 10 leaf texels, so every plate carries
// its digits.
TEST_F(AtlasMapping, EveryBuildingShowsItsOwnNumberPlate) {
    World& w = *world_;
    const int a = w.tree.params.atlas_size_px;
    std::vector<int32_t> facades;
    for (size_t t = 0; t < w.town.textures.size(); ++t)
        if (w.town.textures[t].kind == synth::SynthTexture::Kind::Facade) facades.push_back(static_cast<int32_t>(t));
    ASSERT_EQ(facades.size(), w.town.buildings.size());
    Rng rng{777};
    constexpr int kPointsPerTriangle = 400;
    std::printf("number plates, mean colour error of the leaf atlas against each facade:\n");
    for (size_t b = 0; b < w.town.buildings.size(); ++b) {
        const synth::SynthBuilding& building = w.town.buildings[b];
        const int32_t own = building.facade_texture;
        const UvBox plate = plateBox(w.textures[own]);
        ASSERT_FALSE(plate.empty()) << "the facade of building " << building.number << " has no white plate";
        std::map<int32_t, double> error_sum;
        size_t points = 0;
        for (uint32_t i = 0; i < w.tree.triangles.size(); ++i) {
            const TreeTriangle& t = w.tree.triangles[i];
            if (t.tri.feature != b || t.tri.semantic != SurfaceSemantic::Wall) continue;
            ASSERT_EQ(t.tri.texture, own) << "building " << building.number;
            const AtlasNode& leaf = w.tree.nodes[w.leaf_of[i]];
            const PackedRegion* region = leafRegion(leaf, t, a);
            ASSERT_NE(region, nullptr) << "triangle " << i;
            View v;
            if (!viewIn(leaf, leaf, *region, t, a, &v)) continue;
            const LinearImage* img = w.atlas(leaf.layers[static_cast<int>(t.layer)].atlas_path);
            ASSERT_NE(img, nullptr) << "leaf " << w.leaf_of[i];
            for (int s = 0; s < kPointsPerTriangle; ++s) {
                const auto bary = rng.barycentric();
                const Vec2d uv = mix3(t.tri.uv, bary);
                if (!plate.holdsPeriodic(uv)) continue;
                const Vec2d p = texelsAt(leaf, t.layer, mix3(t.atlas_uv, bary), a);
                ++points;
                for (int32_t f : facades)
                    error_sum[f] +=
                        colourError(probe(*img, *w.boxes[f], w.textures[f].w, w.textures[f].h, p, uv, v.uv_per_texel));
            }
        }
        ASSERT_GE(points, kMinPointsPerLevel) << "building " << building.number << " shows too little of its plate";
        int32_t best = -1, runner_up = -1;
        for (const auto& [f, e] : error_sum) {
            if (best < 0 || e < error_sum[best]) {
                runner_up = best, best = f;
            } else if (runner_up < 0 || e < error_sum[runner_up]) {
                runner_up = f;
            }
        }
        const double n = static_cast<double>(points);
        std::printf("  building %2u: %4zu points, own facade %.4f, best other: building %u's %.4f\n", building.number,
                    points, error_sum[own] / n, w.town.textures[best == own ? runner_up : best].building_number,
                    error_sum[best == own ? runner_up : best] / n);
        EXPECT_EQ(best, own) << "building " << building.number << "'s walls look most like the facade of building "
                             << w.town.textures[best].building_number;
        // Clearly, not by a hair: measured ratios are 2.8 and up.
        EXPECT_GT(error_sum[runner_up], 2 * error_sum[own]) << "building " << building.number;
    }
}

// Synthetic towns make every 7th facade RGBA (glass alpha 0..100): those
// triangles must be drawn from alpha-layer atlases (RGBA files under
// atlas/alpha/) at every level, every other textured triangle from the opaque
// layer, and the atlases' alpha must be the original's, prefiltered.
TEST_F(AtlasMapping, RgbaFacadesLiveInTheAlphaLayerWithTheirAlpha) {
    World& w = *world_;
    size_t rgba_triangles = 0;
    for (uint32_t i = 0; i < w.tree.triangles.size(); ++i) {
        const TreeTriangle& t = w.tree.triangles[i];
        if (t.tri.texture < 0) continue;
        const bool rgba = w.scene.textures[t.tri.texture].channels == 4;
        ASSERT_EQ(t.layer, rgba ? Layer::Alpha : Layer::Opaque) << "triangle " << i;
        if (!rgba) continue;
        ++rgba_triangles;
        for (int32_t id = w.leaf_of[i]; id >= 0; id = w.tree.nodes[id].parent) {
            const NodeLayer& l = w.tree.nodes[id].layers[static_cast<int>(Layer::Alpha)];
            ASSERT_TRUE(i >= l.range.first && i < l.range.first + l.range.count) << "triangle " << i << ", node " << id;
            ASSERT_EQ(l.atlas_path.rfind("atlas/alpha/", 0), 0u) << "node " << id << ": '" << l.atlas_path << "'";
            ASSERT_TRUE(fs::is_regular_file(w.out / l.atlas_path)) << l.atlas_path;
            const LinearImage* img = w.atlas(l.atlas_path);
            ASSERT_NE(img, nullptr) << l.atlas_path;
            ASSERT_EQ(img->channels, 4) << l.atlas_path;
            ASSERT_EQ(img->w, l.width) << l.atlas_path;
        }
    }
    size_t rgba_buildings = 0;
    for (const synth::SynthBuilding& b : w.town.buildings)
        rgba_buildings += w.town.textures[b.facade_texture].channels == 4;
    ASSERT_EQ(rgba_buildings, w.town.buildings.size() / 7);
    ASSERT_GT(rgba_triangles, 0u);

    std::map<int, std::vector<double>> right, shifted;
    forEachLevelSample(w, Layer::Alpha, 999, 32, [&](const TreeTriangle& t, const LevelSample& s) {
        right[s.halvings].push_back(alphaError(probeTexture(w, t.tri.texture, s)));
        shifted[s.halvings].push_back(alphaError(probeTexture(w, t.tri.texture, s, kQuarterShift)));
    });
    if (HasFatalFailure()) return;
    for (int h = 0; h <= 2; ++h) ASSERT_GE(right[h].size(), 10 * kMinPointsPerLevel) << "leaf+" << h;
    // Alpha is stored linearly (8 bits: half a step is 0.002) and filtered
    // like linear-light colour, so the colour tolerances hold for it too.
    // Most of a facade is opaque wall, so the median compares mostly 1 with
    // 1; the 90th percentile reaches the glass.
    std::printf("alpha error |atlas - reference|:\n");
    for (const auto& [h, e] : right) {
        const Stats r = statsOf(e), sh = statsOf(shifted[h]);
        printStats("right texture and uv", h, r);
        printStats("wrong: uv + (0.25, 0.25)", h, sh);
        if (r.n < kMinPointsPerLevel) continue;
        EXPECT_LE(r.median, kMedianTolerance) << "leaf+" << h;
        EXPECT_LE(r.p90, kP90Tolerance) << "leaf+" << h;
        expectDiscriminates("alpha, uv + (0.25, 0.25)", h, r, sh);
    }
}

// The alpha layer's colour: premultiplied (what blending uses), to the same
// tolerances as the opaque layer's, and on the glass itself (reference alpha
// 0.1..0.45, where a colour error is not hidden by a small alpha) as straight
// colour, which 8-bit straight storage keeps to about the same accuracy; the
// division by alpha (at most 1/0.1) magnifies the kernel's differences, so
// the glass gets a wider median bound.
TEST_F(AtlasMapping, AlphaLayerColourMatchesOriginal) {
    World& w = *world_;
    std::map<int, std::vector<double>> premultiplied, glass;
    forEachLevelSample(w, Layer::Alpha, 4242, 32, [&](const TreeTriangle& t, const LevelSample& s) {
        Probe p = probeTexture(w, t.tri.texture, s);
        premultiplied[s.halvings].push_back(colourError(p));
        if (p.ref[3] > 0.1 && p.ref[3] < 0.45 && p.atlas[3] > 0.05) {
            for (int c = 0; c < 3; ++c) p.ref[c] /= p.ref[3], p.atlas[c] /= p.atlas[3];
            glass[s.halvings].push_back(colourError(p));
        }
    });
    if (HasFatalFailure()) return;
    std::printf("alpha layer colour error, linear light, mean over RGB:\n");
    for (const auto& [h, e] : premultiplied) {
        const Stats r = statsOf(e), g = statsOf(glass[h]);
        printStats("premultiplied", h, r);
        printStats("straight, on glass", h, g);
        if (r.n >= kMinPointsPerLevel) {
            EXPECT_LE(r.median, kMedianTolerance) << "premultiplied, leaf+" << h;
            EXPECT_LE(r.p90, kP90Tolerance) << "premultiplied, leaf+" << h;
        }
        if (g.n >= kMinPointsPerLevel) {
            EXPECT_LE(g.median, 5 * kMedianTolerance) << "glass, leaf+" << h;
        }
    }
}

}  // namespace
}  // namespace cityatlas::atlas
