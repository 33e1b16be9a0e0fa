// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The atlas stage: Scene -> AtlasTree, the multiresolution texture-atlas tree
/// of papers/001 §3-5 and papers/000 §4.5.
///
/// Every node owns one A x A atlas per layer that textures all triangles of its
/// subtree well enough for any camera at least `min_distance_m` from the
/// node's bounds: no atlas texel covers more than one screen pixel (tau = 1) at
/// the screen size and field of view the tree was built for. Leaves are filled
/// from the original textures; an inner node's atlas is its children's atlases
/// halved and tiled 2 x 2, so it serves from twice the largest child distance.
///
/// Layers. Triangles whose texture has an alpha channel (or whose material is
/// transparent) are drawn in a second, blended pass; they get their own layer:
/// a second atlas over the SAME partition (papers/000 §5.1.3 "multiple texture
/// layers"), so one traversal selects both, and opaque atlases stay RGB (BC1,
/// half the bytes of BC3). A node is a leaf when both of its layers pack.
///
/// Texture coordinates (papers/000 §4.5.4): every triangle stores ONE set of
/// atlas coordinates, in root-atlas space. Node N at level k uses them as
/// `local = root * 2^k - offset(N)` (an integer offset, so with GL_REPEAT the
/// texture matrix is a plain scale). Child quadrants: 0 bottom-left,
/// 1 bottom-right, 2 top-left, 3 top-right; v = 0 is the bottom of an atlas.
///
/// Triangle order (papers/000 §4.8.1): AtlasTree::triangles is sorted by layer,
/// then by leaf in depth-first order, then by texture, so every node's
/// triangles of one layer are one contiguous range and children's ranges nest
/// inside their parent's: one draw call per node and layer.

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "atlas/packing.h"
#include "ingest/diagnostics.h"
#include "ingest/scene.h"
#include "ingest/status.h"

namespace cityatlas::atlas {

enum class Layer : uint8_t { Opaque = 0, Alpha = 1 };
inline constexpr int kLayerCount = 2;
std::string_view layerName(Layer l);  ///< "opaque", "alpha"

/// Resampling kernel for leaf atlases (inner atlases are always 2x2 box means
/// of their children, which keeps 4-texel-aligned rectangles from bleeding).
enum class ResampleFilter : uint8_t { Box, Triangle, Mitchell, Lanczos3 };
std::string_view filterName(ResampleFilter f);  ///< "box", "triangle", "mitchell", "lanczos3"
std::optional<ResampleFilter> filterFromName(std::string_view name);

struct AtlasParams {
    /// Minimum camera distance for leaf atlases, metres. Unset: the scene's
    /// bounding-box diagonal times `d_min_diagonal_fraction` (the papers' D/72).
    std::optional<double> d_min_m;
    double d_min_diagonal_fraction = 1.0 / 72.0;
    int atlas_size_px = 512;        ///< A, a power of two in [64, 4096]
    int border_px = 8;              ///< b, real texture content around every packed region
    int screen_width_px = 1920;     ///< assumed viewport, for the texel-size estimate
    int screen_height_px = 1080;
    double vertical_fov_deg = 60.0; ///< assumed vertical field of view
    ResampleFilter filter = ResampleFilter::Lanczos3;
    PackingMethod packing = PackingMethod::MaxRects;
    double critical_fraction = 0.10;  ///< c: above it d_min is enlarged, below it triangles are split
    int threads = 0;                  ///< 0 = all cores
    int cache_mb = 256;               ///< OpenImageIO ImageCache budget for original textures
    bool render_images = true;        ///< false: structure, ranges and coordinates only (no files)
};

/// Checks ranges (A a power of two in range, border < A/4, positive screen and
/// fov < 180, fraction in [0, 1]); the message names the parameter.
Status validateParams(const AtlasParams& p);

/// The magnification bound the estimate uses: screen pixels per metre at one
/// metre of distance, anywhere in the view frustum. A segment at Euclidean
/// distance d, seen at angle theta off the view axis, projects to at most
/// f / (d cos^2 theta) pixels per metre (f = focal length in pixels); the
/// papers use theta = 0, which the frustum's corners exceed by 1/cos^2 theta.
struct ProjectionBound {
    double focal_px = 0;        ///< (height / 2) / tan(fov / 2)
    double corner_factor = 1;   ///< 1 / cos^2 of the corner ray's angle = 1 + tan^2
    double pixelsPerMetreAt1m() const { return focal_px * corner_factor; }
};
ProjectionBound projectionBound(const AtlasParams& p);

/// One triangle of the tree: a scene triangle or a piece of a split critical one.
struct TreeTriangle {
    Triangle tri;                       ///< positions, ORIGINAL uv, texture, material, feature, semantic
    std::array<Vec2d, 3> atlas_uv{};    ///< root-atlas coordinates; zero when untextured
    uint32_t source = 0;                ///< index into Scene::triangles
    Layer layer = Layer::Opaque;
};

struct TriangleRange {
    uint32_t first = 0, count = 0;  ///< into AtlasTree::triangles
};

/// One packed region of a leaf atlas: a rectangle of an original texture
/// (with its border) scaled into [x, x+w) x [y, y+h) texels (y up).
struct PackedRegion {
    int32_t texture = -1;
    int x = 0, y = 0, w = 0, h = 0;  ///< texels in the leaf atlas, v-up
    bool rotated = false;            ///< the texture's u runs along the atlas's y
    Vec2d uv_min, uv_max;            ///< source region in texture space, border included
    /// Leaf-atlas texel coordinates (v-up) of a point of the texture.
    Vec2d toAtlasTexels(const Vec2d& uv) const;
    /// The inverse: texture coordinates of a leaf-atlas texel position.
    Vec2d toTexture(const Vec2d& texel) const;
};

struct NodeLayer {
    TriangleRange range;                ///< this layer's triangles of the subtree
    std::string atlas_path;             ///< relative to the output folder; empty when the layer is empty
    std::vector<PackedRegion> regions;  ///< leaves only
    uint64_t packed_texels = 0;         ///< leaves: area of the packed regions
    bool present() const { return range.count > 0 && !atlas_path.empty(); }
};

struct AtlasNode {
    int32_t parent = -1;
    std::array<int32_t, 4> children{-1, -1, -1, -1};  ///< by quadrant; -1 = empty quadrant
    int level = 0;                                      ///< root = 0
    std::array<uint32_t, 2> offset{0, 0};  ///< integer offset of this node's atlas in root space * 2^level
    Box3d bounds;                          ///< of the subtree's triangles
    double min_distance_m = 0;
    std::array<NodeLayer, kLayerCount> layers;
    bool leaf() const { return children == std::array<int32_t, 4>{-1, -1, -1, -1}; }
    /// Root-atlas coordinates -> this node's atlas coordinates in [0,1]^2.
    Vec2d localFromRoot(const Vec2d& root) const;
};

struct StepStats {
    std::string name;
    double seconds = 0;
    double peak_rss_mb = 0;
};

struct AtlasStats {
    double scene_diagonal_m = 0;
    double d_min_requested_m = 0;  ///< from --d-min or the diagonal fraction
    double d_min_used_m = 0;       ///< after enlargement for critical triangles
    /// papers/000 §6.1.2: d_full, the smallest over textures of the distance at which a texture needs
    /// exactly its original resolution; below it EVERY texture is stored above its original resolution.
    double d_full_m = 0;
    /// The largest such distance: below it SOME texture is stored above its original resolution.
    double d_first_upsampled_m = 0;
    uint64_t textures_upsampled = 0;        ///< textures stored above their original resolution at d_min_used
    uint64_t critical_triangles = 0;        ///< at the requested d_min
    uint64_t critical_after_enlarge = 0;    ///< left at d_min_used, then split
    uint64_t triangles_split = 0;           ///< scene triangles split for being critical
    uint64_t triangles_added_by_split = 0;
    bool enlarged_for_split_budget = false; ///< d_min raised beyond the fraction rule to bound splitting
    uint64_t textured_triangles = 0;
    uint64_t degenerate_uv_triangles = 0;   ///< all three uv equal, or collinear
    uint64_t nodes = 0, leaves = 0, atlases = 0;
    int depth = 0;
    uint64_t packed_texels = 0;             ///< over all leaf atlases
    uint64_t leaf_atlas_texels = 0;         ///< leaf atlases x A^2
    uint64_t original_texture_bytes = 0;    ///< uncompressed, of the textures used, at 8 bits per channel
    uint64_t atlas_texture_bytes = 0;       ///< uncompressed RGB / RGBA atlases over all nodes
    uint64_t textures_unreadable = 0;
    uint64_t leaves_below_resolution = 0;   ///< forced leaves (see the atlas_resolution_lowered warning)
    std::vector<StepStats> steps;
};

struct AtlasTree {
    AtlasParams params;          ///< as used
    ProjectionBound projection;
    std::vector<AtlasNode> nodes;            ///< depth-first preorder; nodes[0] is the root
    std::vector<TreeTriangle> triangles;     ///< ordered as the file comment says
    AtlasStats stats;
};

using AtlasProgressFn = std::function<void(const char* step, uint64_t done, uint64_t total)>;

/// Builds the tree and writes every node's atlas images (PNG, 8-bit sRGB) to
/// `output_dir/atlas/<layer>/<node>.png`, each as soon as it is finished.
/// Original textures are read on demand through an ImageCache bounded by
/// params.cache_mb; nodes are built in parallel, with identical results for any
/// thread count. Unreadable textures are counted in `diagnostics`
/// (their regions are filled with mid grey) and do not stop the build.
Status buildAtlasTree(const Scene& scene, const AtlasParams& params, const std::filesystem::path& output_dir,
                      Diagnostics& diagnostics, const AtlasProgressFn& progress, AtlasTree* tree);

}  // namespace cityatlas::atlas
