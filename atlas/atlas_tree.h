// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The atlas stage: Scene -> AtlasTree, the multiresolution texture-atlas tree
/// of papers/001 §3-5 and papers/000 §4.5.
///
/// Every node owns one atlas per layer, at most A x A and only as large as its
/// content, that textures all triangles of its subtree well enough for any
/// camera at least `min_distance_m` from the node's bounds: no atlas texel
/// covers more than one screen pixel (tau = 1) at the screen size and field of
/// view the tree was built for. Leaves are filled from the original textures;
/// an inner node's atlas packs its children's atlases halved (placement.h:
/// per-layer texel offsets), so it serves from twice its children's largest
/// `sharp_from_m`.
///
/// Layers. Triangles whose texture has an alpha channel (or whose material is
/// transparent) are drawn in a second, blended pass; they get their own layer:
/// a second atlas over the SAME partition (papers/000 §5.1.3 "multiple texture
/// layers"), so one traversal selects both, and opaque atlases stay RGB (BC1,
/// half the bytes of BC3). A node is a leaf when both of its layers pack.
///
/// Resolution cap. No atlas region is stored above its original texture's
/// resolution, per axis: where a camera at d_min would need more texels than
/// the texture has, the region holds the texture's own texels (aligned to
/// them, so it is an exact copy). The guarantee is therefore: from a node's
/// min distance on, no atlas texel covers more than one pixel, or the atlas
/// holds that texture at its full resolution. A leaf's `sharp_from_m` is the
/// distance from which even its capped regions' texels are at most a pixel;
/// its parent, which holds them halved, serves from twice the largest
/// child's sharp_from_m (without capped regions that is the papers'
/// 2 x min distance).
///
/// Atlas sizes. Each node layer's atlas is only as large as its content: a
/// leaf takes the smallest w x h (sides multiples of A/16, aspect at most 2:1,
/// at most A x A) its regions pack into; an inner node packs its children's
/// atlases, halved, as four unrotated rectangles into the smallest w x h that
/// holds them (at most A x A: four halves always fit).
///
/// Texture coordinates (papers/000 §4.5.4): every triangle stores ONE set of
/// atlas coordinates, in root-atlas space (units of A texels at level 0).
/// Node layer N at level k uses them as `texel = root * A * 2^k - offset(N)`
/// with an integer texel offset, so one scale per level and one integer
/// translation per node map them into any ancestor's atlas. A child placed at
/// texel p of its parent has offset(child) = 2 * (offset(parent) + p).
/// Child quadrants (spatial, of the subdivision): 0 bottom-left,
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
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "atlas/packing.h"
#include "format/dds.h"
#include "ingest/diagnostics.h"
#include "ingest/scene.h"
#include "core/status.h"

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
    /// Minimum camera distance for leaf atlases, metres. Unset: chosen from the
    /// data (`d_min_from_data`, the default), or the scene's bounding-box
    /// diagonal times `d_min_diagonal_fraction` (the papers' D/72).
    std::optional<double> d_min_m;
    double d_min_diagonal_fraction = 1.0 / 72.0;
    int atlas_size_px = 512;        ///< A, a power of two in [64, 4096]
    int border_px = 8;              ///< b, real texture content around every packed region
    int screen_width_px = 1920;     ///< assumed viewport, for the texel-size estimate
    int screen_height_px = 1080;
    double vertical_fov_deg = 60.0; ///< assumed vertical field of view
    /// When d_min_m is unset: true = chosen from the data (chooseDefaultDmin), false = the diagonal fraction.
    bool d_min_from_data = true;
    ResampleFilter filter = ResampleFilter::Lanczos3;
    PackingMethod packing = PackingMethod::MaxRects;
    double critical_fraction = 0.10;  ///< c: above it d_min is enlarged, below it triangles are split
    int threads = 0;                  ///< 0 = all cores
    int cache_mb = 256;               ///< memory for decoded original textures, kept for leaves that share them
    /// Memory for the scene-wide texture models of decideGlobals (48 bytes a
    /// textured triangle): a scene whose models need more is planned a
    /// range of textures at a time, a pass over its triangles each. Does not
    /// change the output.
    uint64_t model_budget_bytes = uint64_t{256} << 20;
    /// No two world-distinct triangles share atlas texels (charts.h
    /// surfaceComponents): what a computed texture over the atlas
    /// coordinates needs. Off: triangles that reuse one part of a texture
    /// (real CityGML walls mapping one photo 0..1) share its texels.
    bool unique_charts = false;
    bool render_images = true;        ///< false: structure, ranges and coordinates only (no files)
    /// The level of this tree's root in the tree it is part of (a shard's
    /// subtree, cli/shards.h): the depth rules (count-balanced cuts from level
    /// 16, forced leaves at 31) count from the whole tree's root. Not a user option.
    int base_level = 0;
    bool keep_root_halves = false;    ///< keep AtlasTree::root_halves (a shard's root). Not a user option.
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
    /// Content at the texture's own resolution on that axis (the cap applied):
    /// one atlas texel per texture texel, aligned to them.
    bool native_u = false, native_v = false;
    /// Distance from which this region's texels cover at most one pixel: <= d_min
    /// unless the region is capped.
    double sharp_from_m = 0;
    bool single_colour = false;      ///< every triangle has one uv: one colour, exact at any size
    /// The triangles' uv box (border excluded) and the texels it takes at the
    /// stored density before borders and block rounding (the texel budget).
    Vec2d content_uv_min, content_uv_max;
    double content_w = 0, content_h = 0;
    /// Texels of real texture around the content on each side, along u and v
    /// (the --border, or less for small content: texel_estimate.h borderFor).
    int border_u = 0, border_v = 0;
    /// No original adds texels to this region: capped on both axes, or one colour.
    bool exact() const { return single_colour || (native_u && native_v); }
    /// Leaf-atlas texel coordinates (v-up) of a point of the texture.
    Vec2d toAtlasTexels(const Vec2d& uv) const;
    /// The inverse: texture coordinates of a leaf-atlas texel position.
    Vec2d toTexture(const Vec2d& texel) const;
};

struct NodeLayer {
    TriangleRange range;                ///< this layer's triangles of the subtree
    std::string atlas_path;             ///< relative to the output folder; empty when the layer is empty
    int width = 0, height = 0;          ///< the atlas image, texels (0 without an atlas)
    std::array<int64_t, 2> offset{0, 0};  ///< texels: local texel = root * A * 2^level - offset
    std::vector<PackedRegion> regions;  ///< leaves only
    uint64_t packed_texels = 0;         ///< leaves: area of the packed regions
    bool present() const { return range.count > 0 && !atlas_path.empty(); }
    /// Root-atlas coordinates -> texels of this atlas (v up), for a node at `level`.
    Vec2d texelFromRoot(const Vec2d& root, int level, int atlas_size) const;
    /// Root-atlas coordinates -> this atlas's texture coordinates in [0,1]^2.
    Vec2d localFromRoot(const Vec2d& root, int level, int atlas_size) const;
};

struct AtlasNode {
    int32_t parent = -1;
    std::array<int32_t, 4> children{-1, -1, -1, -1};  ///< by quadrant; -1 = empty quadrant
    int level = 0;                                      ///< root = 0
    Box3d bounds;                          ///< of the subtree's triangles
    double min_distance_m = 0;
    /// From here on every texel of this node's atlases covers at most one pixel:
    /// min_distance_m, or more for a leaf with capped regions (the largest region's).
    double sharp_from_m = 0;
    std::array<NodeLayer, kLayerCount> layers;
    /// Leaves: the scene textures (ascending) whose atlas regions here are below
    /// their own resolution, so the original adds texels for cameras closer than
    /// min_distance_m. Empty: the atlas is exact and draws at any distance.
    std::vector<int32_t> originals;
    bool leaf() const { return children == std::array<int32_t, 4>{-1, -1, -1, -1}; }
};

struct StepStats {
    std::string name;
    double seconds = 0;
    double peak_rss_mb = 0;
    double cpu_seconds = 0;  ///< user + system over all threads (core/resource_usage.h)
};

/// Every level-0 atlas texel of the tree, by what it holds. The parts add up
/// to total(): the sum of all atlases' width x height.
struct TexelBudget {
    uint64_t content_required = 0;  ///< leaf region content at the resolution d_min asks for (first period)
    uint64_t content_native = 0;    ///< leaf region content capped at the texture's own resolution (first period)
    uint64_t repeats = 0;           ///< replicated periods of repeating textures beyond the first
    uint64_t borders = 0;           ///< the border of real texture content around each region
    uint64_t rounding = 0;          ///< regions widened to whole 4x4 blocks and to native texel boundaries
    uint64_t empty = 0;             ///< leaf atlas texels that no region covers
    uint64_t inner = 0;             ///< the atlases of inner nodes (their children halved)
    uint64_t total() const { return content_required + content_native + repeats + borders + rounding + empty + inner; }
};

/// Bytes as BC1 (opaque) / BC3 (alpha) with full mip chains and a DDS header,
/// the form the tiles stage writes.
struct ByteBudget {
    uint64_t atlases = 0;            ///< every atlas of the tree
    uint64_t originals_used = 0;     ///< every original texture a triangle uses
    uint64_t originals_needed = 0;   ///< the originals some leaf needs closer than its min distance
    /// (atlases + originals needed) / originals used: what the tree costs over the data; 0 without textures.
    double ratio() const {
        return originals_used ? static_cast<double>(atlases + originals_needed) / static_cast<double>(originals_used) : 0;
    }
};

/// How d_min was chosen when --d-min was not given (chooseDefaultDmin).
struct DminChoice {
    std::string rule;          ///< "given", "diagonal-fraction", "data"
    std::string reason;        ///< one sentence for the user
    double estimated_ratio = 0;          ///< ByteBudget::ratio() the estimate predicted at the chosen value
    double originals_within_m_mb = 0;    ///< largest original-texture MB any camera needs within d_min (estimate)
    struct Candidate {
        double d_m = 0, ratio = 0, originals_within_mb = 0;
    };
    std::vector<Candidate> candidates;   ///< rule "data": every distance the estimate tried, ascending
};

struct AtlasStats {
    double scene_diagonal_m = 0;
    DminChoice d_min_choice;
    double d_min_requested_m = 0;  ///< from --d-min, the data, or the diagonal fraction
    double d_min_used_m = 0;       ///< after enlargement for critical triangles
    /// papers/000 §6.1.2: d_full, the smallest over textures of the distance at which a texture needs
    /// exactly its original resolution; below it EVERY texture is stored above its original resolution.
    double d_full_m = 0;
    /// The largest such distance: below it SOME texture is stored above its original resolution.
    double d_first_upsampled_m = 0;
    uint64_t textures_upsampled = 0;        ///< textures whose d_min resolution exceeds their own (capped)
    uint64_t textures_exact = 0;            ///< held at full resolution wherever used: no original needed
    uint64_t textures_needing_originals = 0;
    TexelBudget texels;
    ByteBudget bytes;
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
    uint64_t leaf_atlas_texels = 0;         ///< sum of leaf atlases' width x height
    uint64_t original_texture_bytes = 0;    ///< uncompressed, of the textures used, at 8 bits per channel
    uint64_t atlas_texture_bytes = 0;       ///< uncompressed RGB / RGBA atlases over all nodes
    uint64_t textures_unreadable = 0;
    uint64_t leaves_below_resolution = 0;   ///< forced leaves (see the atlas_resolution_lowered warning)
    std::vector<StepStats> steps;
};

/// What the whole scene decides for every node (buildAtlasTree's first pass):
/// the scene's extent, d_min as requested and as enlarged for critical
/// triangles, d_full, and the textures promoted to full resolution. A shard
/// of a larger build gets the plan's (decideGlobals over the whole input), so
/// its nodes are the ones the whole tree would give them.
struct GlobalDecisions {
    double scene_diagonal_m = 0;
    DminChoice d_min_choice;
    double d_min_requested_m = 0, d_min_used_m = 0;
    double d_full_m = 0, d_first_upsampled_m = 0;
    uint64_t textured_triangles = 0, degenerate_uv_triangles = 0;
    uint64_t critical_triangles = 0;  ///< at the requested d_min
    bool enlarged_for_split_budget = false;
    std::vector<uint8_t> promote;     ///< per scene texture: held at full resolution (texture_economy.h)
};

/// The whole scene's GlobalDecisions (the first pass of buildAtlasTree).
Status decideGlobals(const Scene& scene, const AtlasParams& params, GlobalDecisions* out);

/// One pass over every triangle of the scene, in scene order, each handed to
/// `fn` (the scene in memory, or its spill file read again); `step` names
/// the pass for progress reports.
using TrianglePass = std::function<Status(const std::function<void(const Triangle&)>& fn, const char* step)>;

/// decideGlobals over triangles read in passes (an input never held whole).
/// Memory: about 40 bytes a texture, the critical triangles' distances, and
/// the texture models (48 bytes a textured triangle, counted as allocated,
/// and 128 a texture) of at most params.model_budget_bytes at a time. A scene whose models fit is read
/// twice; one whose models do not, once more per batch of textures for the
/// promotions and, with d_min chosen from the data, per batch and round of
/// candidate distances (default_dmin.h). The decisions are the same either way.
Status decideGlobals(const TextureTable& textures, const AtlasParams& params, const TrianglePass& pass,
                     GlobalDecisions* out);

/// An atlas image in linear light, premultiplied RGBA floats, rows bottom-up
/// (v up): what the renderer composes inner atlases from.
struct AtlasCanvas {
    int w = 0, h = 0;
    std::vector<float> px;  ///< w * h * 4
    AtlasCanvas() = default;
    AtlasCanvas(int width, int height) : w(width), h(height), px(static_cast<size_t>(width) * height * 4, 0.0f) {}
    float* at(int x, int y) { return &px[(static_cast<size_t>(y) * w + x) * 4]; }
    const float* at(int x, int y) const { return &px[(static_cast<size_t>(y) * w + x) * 4]; }
};
/// Per layer, a node's atlas halved: what its parent places (absent: no atlas).
using AtlasHalves = std::array<std::optional<AtlasCanvas>, 2>;

struct AtlasTree {
    AtlasParams params;          ///< as used
    ProjectionBound projection;
    std::vector<AtlasNode> nodes;            ///< depth-first preorder; nodes[0] is the root
    std::vector<TreeTriangle> triangles;     ///< ordered as the file comment says
    AtlasStats stats;
    /// With params.keep_root_halves: the root's atlases halved, for the tree
    /// this one is a shard of (its merge places them in the parent's atlas).
    AtlasHalves root_halves;
};

using AtlasProgressFn = std::function<void(const char* step, uint64_t done, uint64_t total)>;

/// Bytes of a DDS with a full mip chain of a w x h image in BC1 (3 channels) or BC3 (4).
uint64_t bcBytesWithMips(int width, int height, int channels);

/// Receives each finished atlas image instead of its PNG: 8-bit sRGB, rows
/// top-down, 3 channels (opaque layer) or 4 with straight alpha (alpha layer),
/// exactly the bytes the PNG would hold. Called from worker threads, any
/// order, once per present node layer; a failed status stops the build. This
/// is how `build` hands atlases to the tile encoder in memory.
using AtlasImageSink = std::function<Status(int32_t node, Layer layer, const format::Image8& image)>;

/// Builds the tree and writes every node's atlas images (PNG, 8-bit sRGB) to
/// `output_dir/atlas/<layer>/<node>.png`, each as soon as it is finished, or
/// hands them to `sink` when one is given (no PNG then).
/// Original textures are read on demand and kept, decoded, within
/// params.cache_mb; nodes are built in parallel, with identical results for any
/// thread count. Unreadable textures are counted in `diagnostics`
/// (their regions are filled with mid grey) and do not stop the build.
///
/// `consume_triangles`: the caller's own `scene.triangles`, given up once the
/// estimate has read them (the tree's working copy takes them instead of a
/// copy: 136 bytes a triangle less at the stage's peak); empty afterwards.
///
/// `globals`: decisions made over a larger scene that `scene` is part of (a
/// shard): used as given instead of decideGlobals(scene), critical triangles
/// split at its d_min_used without enlarging it. The stats report them.
Status buildAtlasTree(const Scene& scene, const AtlasParams& params, const std::filesystem::path& output_dir,
                      Diagnostics& diagnostics, const AtlasProgressFn& progress, AtlasTree* tree,
                      const AtlasImageSink& sink = {}, std::vector<Triangle>* consume_triangles = nullptr,
                      const GlobalDecisions* globals = nullptr);

/// Writes an atlas image as buildAtlasTree does without a sink: PNG, fastest
/// deflate (an intermediate), sRGB, straight alpha.
Status writeAtlasPng(const format::Image8& image, const std::filesystem::path& path);

}  // namespace cityatlas::atlas
