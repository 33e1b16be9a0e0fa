// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The streaming client: one render thread ties the GL-free core (selection,
/// usage classification, the block budget) to the loader (files or HTTP,
/// decoding on worker threads) and the OpenGL backend. Used by `cityatlas
/// render` (headless, EGL) and `cityatlas view` (a GLFW window); both make a
/// context current before initGl() and keep it current on the calling thread.
///
/// Per frame: take finished loads and upload them within a time budget (a
/// block becomes resident when it is on the GPU), classify blocks for the
/// camera, let the BlockManager plan requests / cancellations / evictions,
/// hand those to the loader and free evicted GPU memory, select the draws
/// (Fig. 30: refine only when possible) and draw them.

#include <cstdint>
#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "render/gl/blockmap_pass.h"
#include "render/gl/edge_pass.h"
#include "render/core/block_manager.h"
#include "render/core/computed_ramp.h"
#include "format/feature_bounds.h"
#include "render/core/lenses.h"
#include "render/core/picking.h"
#include "render/core/selection.h"
#include "render/core/tileset_index.h"
#include "render/core/view.h"
#include "render/loader/loader.h"

namespace cityatlas::render {

class GlRenderer;

enum class TextureMode : uint8_t {
    AtlasTree,  ///< the atlas tree with original textures close by (the product)
    Original,   ///< reference: every leaf with its original textures, everything loaded
    Dummy,      ///< reference: the atlas tree's draws with one dummy texture (no texture switches)
};
const char* textureModeName(TextureMode mode);  ///< "atlas", "original", "dummy"

struct ClientOptions {
    uint64_t budget_bytes = 512ull << 20;  ///< summed block sizes resident (tileset.json sizes)
    uint32_t max_requests = 16;            ///< bounded request queue
    double upload_ms_per_frame = 8;        ///< GPU uploads per frame stop after this (at least one per frame)
    SelectionParams selection;
    TextureMode mode = TextureMode::AtlasTree;
    float max_anisotropy = 4;              ///< 1 = off
    bool cpu_decode = false;               ///< S3TC decoded on the CPU, RGBA8 on the GPU (slow compressed sampling, llvmpipe)
    LoaderOptions loader;
    /// Speed policy (papers/004 §4.5): while the camera moves faster than
    /// this (m/s, setCameraSpeed), only Needed geometry and atlas blocks are
    /// requested: no original textures, no prefetch of culled or
    /// parent-needed blocks. 0: off.
    double speed_limit_mps = 0;
    /// The continuous alternative: tau grows with speed, tau * max(1, v / k)
    /// (coarser atlases suffice while moving). 0: off.
    double tau_speed_mps = 0;
    /// Preload (papers/004's low resolution for the whole model): the
    /// geometry and atlases of every node of level <= L lead the priorities
    /// whatever the camera, so no frame after a teleport is coarser than
    /// level L. L is lowered until those blocks fit a quarter of the budget
    /// (preloadLevel() says which L). -1: off.
    int preload_levels = -1;
    /// Look-ahead (papers/004 §3.1: what "will be close to the viewing
    /// point in the near future"): blocks are classified for the camera and
    /// for the camera moved by its velocity times this many seconds, each
    /// block keeping the better of its two priorities, under the same budget.
    /// 0: off.
    double lookahead_s = 0;
    /// Smooth refinement: seconds over which a node's replacement (its
    /// children, or a leaf's originals, or coarser back) fades in over it
    /// (a screen-door dither; GlRenderer::setFade). Fading out never holds
    /// a block: a node whose blocks were evicted stops at once. 0: off.
    double fade_s = 0.25;
    /// A leaf loads only the texture blocks its camera sees (in the frustum,
    /// closer than its min distance; SelectionParams::texture_use), once its
    /// geometry told where it samples each. Off: all of a leaf's blocks load
    /// with it (the behaviour before; for comparisons).
    bool textures_by_view = true;
    /// A computed texture to show (issue 19; TilesetIndex::computed, -1:
    /// none) and how. Only its blocks are requested (inactive ones never are,
    /// selection.h), under the same budget; a node whose block is not
    /// resident yet draws with the photo.
    int computed = -1;
    ComputedStyle computed_style{ComputedMode::Ramp};
};

/// What one frame did; the per-frame report of `cityatlas render`.
struct FrameRecord {
    double frame_ms = 0;         ///< CPU wall time of the frame: uploads, planning, selection, drawing (GL finished)
    double upload_ms = 0;
    uint32_t uploads = 0;
    uint32_t nodes_atlas = 0, nodes_originals = 0, nodes_coarse = 0;
    uint32_t nodes_blockmap = 0;  ///< nodes drawn by their BlockMap (issue 20)
    int coarse_level_min = -1;   ///< the lowest level drawn coarse (its refinement not possible yet); -1: none
    uint32_t lens_occluders = 0; ///< buildings the lenses styled away from normal (occluders, or all but the solo one)
    std::vector<uint32_t> lens_occluder_ids;  ///< the occlusion lens's occluders, ascending (none listed with solo)
    uint32_t fading = 0;         ///< node draws in a cross-fade (in or out)
    uint64_t wasted_bytes = 0;   ///< so far: bytes of blocks evicted without ever being drawn
    uint32_t draw_calls = 0, texture_binds = 0, triangles = 0;
    bool root_missing = false;   ///< nothing could be drawn (the root is not resident yet)
    uint64_t resident_bytes = 0, requested_bytes = 0, budget_bytes = 0;
    uint64_t pinned_bytes = 0;   ///< the feature bounds, held from open on, inside the budget (blocks get the rest)
    uint64_t gpu_bytes = 0;      ///< meshes and textures as stored on the GPU
    uint64_t bytes_loaded = 0;   ///< fetched since the previous frame (files read or transferred; not RAM hits)
    uint64_t ram_hits = 0;       ///< requests served from the RAM level since the previous frame
    uint64_t ram_bytes = 0;      ///< bytes the RAM level holds (<= ram_budget_bytes)
    uint64_t ram_budget_bytes = 0;
    uint64_t ideal_bytes = 0;    ///< bytes of this frame's ideal set
    uint64_t needed_bytes = 0;   ///< of those, the Needed blocks' (what this frame shows at full refinement)
    double speed_mps = 0;        ///< the camera speed the frame was planned with
    bool speed_limited = false;  ///< the speed policy held requests back
    std::array<uint32_t, kBlockKinds> requests{};  ///< requests made since the previous frame, by BlockKind
    std::array<uint32_t, kBlockKinds> ideal_blocks_by_kind{};  ///< this frame's ideal set, by BlockKind
    /// Node layers drawn in a computed mode without their computed block
    /// (the photo stood in): 0 at rest when the budget holds the ideal set.
    uint32_t computed_missing_draws = 0;
    uint32_t requests_in_flight = 0;
    uint32_t ideal_blocks = 0, ideal_missing = 0, needed_missing = 0;
    bool ideal_cut = false;
    uint64_t errors = 0;         ///< failed loads so far
    uint32_t failed_blocks = 0;  ///< blocks failed now (transient ones are tried again after a cool-down)
    uint64_t evictions = 0, cancellations = 0;  ///< so far
};

class StreamingClient {
public:
    /// Reads BASE/tileset.json (a folder or an http(s) URL) and the feature
    /// bounds (format/feature_bounds.h: pinned, counted in the budget), checks
    /// that they and the root fit the budget and starts the loader. One line
    /// on failure; a bounds file that cannot be read or decoded is an error
    /// in errors() and leaves its features without bounds.
    static std::unique_ptr<StreamingClient> open(const std::string& base, const ClientOptions& options, Status* status);
    ~StreamingClient();
    StreamingClient(const StreamingClient&) = delete;
    StreamingClient& operator=(const StreamingClient&) = delete;

    /// Creates the GL renderer; the context must be current on this thread.
    Status initGl();

    /// One frame for `camera` into the framebuffer bound now.
    FrameRecord frame(const Camera& camera);

    /// Plans and loads (uploading as results arrive) without drawing until
    /// every block of the ideal set for `camera` is resident, or `timeout_s`
    /// passes. False on timeout. Used for images that must not depend on
    /// timing ("wait for the ideal set") and to load the root before the first
    /// frame.
    bool waitForIdealSet(const Camera& camera, double timeout_s);
    /// Between frames: uploads finished loads and plans for `camera` until
    /// `seconds` have passed (a real-time viewer's idle time within its frame
    /// interval), returning early only when nothing is left to do.
    void idle(const Camera& camera, double seconds);

    /// Loads until the root's blocks are resident (the first thing any frame
    /// needs), planning for `camera`. A transient failure of a root block (a
    /// flaky server outlasting the loader's retries) is waited out; an error
    /// when a root block failed for good (a 404, bytes that do not decode),
    /// naming its error, or on timeout, naming the first error seen.
    Status waitForRoot(const Camera& camera, double timeout_s);

    /// The building under pixel (px, py) of the last frame drawn with `camera`
    /// (a CPU ray cast against the drawn nodes' resident geometry).
    PickHit pick(const Camera& camera, double px, double py) const;
    /// The feature's record from its feature table (fetched once per table), as JSON text.
    Status featureRecord(uint32_t feature, std::string* json_text);

    const TilesetIndex& index() const { return index_; }
    /// Per feature id (index().feature_count of them, or as many as the
    /// listed tables can hold when that is fewer); a record without
    /// kHasGeometry where a file was missing or damaged.
    const std::vector<format::FeatureBoundsRecord>& featureBounds() const { return feature_bounds_; }
    /// Bytes of the feature bounds, inside the budget.
    uint64_t pinnedBytes() const { return pinned_bytes_; }
    /// The level up to which every node is preloaded (ClientOptions::preload_levels, lowered to fit); -1: none.
    int preloadLevel() const { return preload_level_; }
    const ClientOptions& options() const { return options_; }
    void setBudget(uint64_t bytes);
    void setTau(double tau) { options_.selection.tau = tau; }
    /// Information lenses from the next frame on (render/core/lenses.h); they
    /// need the feature bounds (a folder without them draws every building normally).
    void setLens(const LensParams& lens) { lens_ = lens; }
    const LensParams& lens() const { return lens_; }
    /// The time of the next frame (seconds, increasing: a camera path's time)
    /// for the cross-fades; without it, seconds since open().
    void setFrameTime(double seconds) { frame_time_s_ = seconds; }
    /// The camera's velocity (m/s, local frame) for the speed policies and
    /// the look-ahead; zero at a teleport.
    void setCameraVelocity(const Vec3d& v) {
        velocity_ = v;
        speed_mps_ = length(v);
    }
    void setMode(TextureMode mode) { options_.mode = mode; }
    /// The computed texture shown from the next frame on (-1: none); see ClientOptions::computed.
    void setComputed(int computed, const ComputedStyle& style) {
        options_.computed = computed;
        options_.computed_style = style;
    }
    /// Edge enhancement (render/gl/edge_pass.h) from the next frame on, over
    /// `target` (made with an id buffer; the frames must be drawn into it),
    /// inside the frame's time; off with style.enabled false. A failure is
    /// one line in errors() and turns it off.
    void setEdges(const EdgeStyle& style, const OffscreenTarget* target) {
        edges_ = style;
        edge_target_ = target;
    }
    /// Every load error so far, one line each (uri: what), in order.
    const std::vector<std::string>& errors() const { return errors_; }
    const LoaderStats loaderStats() const;
    bool usesCpuDecode() const;

private:
    StreamingClient() = default;
    struct Resident;
    void loadFeatureBounds();
    struct Fade {
        DrawItem item;
        float progress = 0;
        bool out = false;
        double started = 0;
    };
    struct Shown {
        DrawMode mode = DrawMode::Atlas;
        double since = 0;  ///< when it started fading in (-1e300: it appeared at once)
    };
    std::vector<Fade> crossFades(const Selection& sel);
    bool related(int32_t a, int32_t b) const;
    double now() const;
    void choosePreloadLevel();
    Classification classify(const Camera& camera) const;
    void plan(const Camera& camera);
    void takeResults();
    uint32_t upload(double budget_ms, double* spent_ms);
    void release(BlockId id);
    /// Records where a leaf's decoded geometry samples its texture blocks (texture_use_).
    void noteTextureUse(BlockId geometry, const MeshData& mesh);
    Selection selectForMode(const Camera& camera) const;
    /// The selection parameters at the current camera speed (tau_speed_mps).
    SelectionParams selectionNow() const;
    bool speedLimited() const { return options_.speed_limit_mps > 0 && speed_mps_ > options_.speed_limit_mps; }

    std::string base_;
    ClientOptions options_;
    TilesetIndex index_;
    std::unique_ptr<Loader> loader_;
    std::unique_ptr<BlockManager> manager_;
    std::unique_ptr<GlRenderer> gl_;
    std::unique_ptr<BlockMapPass> blockmap_pass_;  ///< made on the first BlockMap block
    EdgeStyle edges_;
    const OffscreenTarget* edge_target_ = nullptr;
    std::unique_ptr<Resident> resident_;
    std::vector<LoadResult> arrived_;  ///< finished loads waiting for their upload
    std::vector<std::string> errors_;
    std::vector<DrawItem> last_drawn_;                   ///< what the last frame drew
    std::map<size_t, std::string> feature_tables_;       ///< fetched tables by index
    std::vector<format::FeatureBoundsRecord> feature_bounds_;
    uint64_t pinned_bytes_ = 0;
    uint64_t bytes_fetched_seen_ = 0;
    uint64_t ram_hits_seen_ = 0;
    uint64_t plans_ = 0;  ///< ideal sets that changed: the RAM level's clock
    std::vector<BlockId> touched_ideal_;  ///< the ideal set the RAM level was last stamped with
    double speed_mps_ = 0;
    Vec3d velocity_{0, 0, 0};
    int preload_level_ = -1;
    LensParams lens_;
    std::map<int32_t, Shown> shown_;     ///< nodes drawn in the last frame
    std::vector<Fade> fading_out_;
    double frame_time_s_ = -1;
    std::vector<uint8_t> drawn_;  ///< per block: drawn since it became resident
    TextureUseMap texture_use_;   ///< per block: leaves' geometry, where it samples its texture blocks (kept past eviction)
    uint64_t wasted_bytes_ = 0;
    std::chrono::steady_clock::time_point opened_ = std::chrono::steady_clock::now();
    LensStyle last_lens_;
    bool lens_uploaded_ = false;
    std::array<uint32_t, kBlockKinds> requests_{};  ///< by BlockKind, since the last frame record
    uint32_t computed_missing_ = 0;                  ///< this frame's (FrameRecord::computed_missing_draws)
};

}  // namespace cityatlas::render
