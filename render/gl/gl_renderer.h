// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// The thin OpenGL 3.3 core backend: uploads decoded blocks (render/core/
/// decoded.h) and draws node layers camera-relative. Needs a current context
/// (gl_context.h) for every call, on the thread it is current on.
///
/// Colour: linear light
/// --------------------
/// Textures are sRGB-encoded and their mips were made in linear light
/// (tiles/texture_codec.h); material colours are linear (MaterialInfo). So
/// textures are uploaded with sRGB formats (the sampler decodes to linear,
/// filtering and mip blending happen in linear light as in the build), the
/// shader works in linear light, and the target is GL_SRGB8_ALPHA8 with
/// GL_FRAMEBUFFER_SRGB (the blend happens in linear light, the stored bytes are
/// sRGB). A texel seen at 1:1 therefore reads back as its own sRGB byte; a
/// material diffuse d reads back as srgb(d). The same holds in all three modes
/// and in the CPU-decode fallback (decoded blocks go up as GL_SRGB8_ALPHA8).
///
/// Frames and precision
/// --------------------
/// Mesh positions are float32 relative to their node's centre; each draw's
/// translation (node_centre - camera.position) is computed in double on the
/// CPU and only then rounded to float, the view matrix is viewRotation(camera)
/// (no translation) and the projection projection(camera). float32 therefore
/// never holds an ECEF-sized coordinate.
///
/// Near and far planes are the caller's: pick them per frame from the boxes of
/// the drawn nodes (near = the smallest distance to a box, clamped to >= 0.1 m,
/// far = the largest distance to a box corner) so the 24-bit depth buffer keeps
/// its resolution where the geometry is.
///
/// Texture coordinates follow the project convention (v = 0 at the BOTTOM of
/// the image, as decodeTileGlb returns them); DDS rows are stored top row
/// first, so the shader samples (u, 1 - v).

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "core/geometry.h"
#include "core/status.h"
#include "render/core/computed_ramp.h"
#include "render/core/decoded.h"
#include "render/core/lenses.h"
#include "render/core/tileset_index.h"
#include "render/core/view.h"
#include "render/gl/blockmap_pass.h"
#include "render/gl/edge_pass.h"

namespace cityatlas::render {

/// A framebuffer object to render into without a window: GL_SRGB8_ALPHA8
/// colour and 24-bit depth renderbuffers, and optionally an id buffer.
///
/// The id buffer (`with_ids`) is a GL_R32UI colour attachment (draw buffer 1)
/// that every draw writes its fragments' feature ids into (the GLB's
/// _FEATURE_ID_0, the building index; kNoFeature where nothing was drawn).
/// Integer attachments are not blended, so an alpha-layer fragment in front
/// of the opaque surface writes its own id: the id is the nearest drawn
/// surface's, as the CPU ray cast (render/core/picking.h) finds it, except
/// where two translucent surfaces of one node overlap (a node's triangles
/// are drawn in order, without depth writes in the alpha layer).
class OffscreenTarget {
public:
    /// The id buffer's value where nothing was drawn.
    static constexpr uint32_t kNoFeature = 0xFFFFFFFFu;

    /// Fails (nullptr, one line) on a non-positive size, a size above
    /// GL_MAX_RENDERBUFFER_SIZE or an incomplete framebuffer.
    static std::unique_ptr<OffscreenTarget> create(int width, int height, Status* status, bool with_ids = false);
    ~OffscreenTarget();
    OffscreenTarget(const OffscreenTarget&) = delete;
    OffscreenTarget& operator=(const OffscreenTarget&) = delete;

    /// Binds the framebuffer for drawing and reading and sets the viewport to it.
    void bind() const;
    /// The colour buffer as RGBA8 (sRGB-encoded bytes, as stored), rows top-down
    /// (first row = top of the picture), width * height * 4 bytes.
    void readPixels(std::vector<uint8_t>* rgba) const;
    /// The id buffer, width * height feature ids, rows top-down; false (and
    /// nothing read) for a target made without one.
    bool readIds(std::vector<uint32_t>* ids) const;
    /// The depth buffer as window depths in [0, 1] (24-bit values as float),
    /// width * height, rows top-down (tests compare surfaces with planes).
    void readDepth(std::vector<float>* depth) const;
    /// The feature id at pixel (x, y) from the top left; kNoFeature outside
    /// the target, where nothing was drawn, or without an id buffer.
    uint32_t idAt(int x, int y) const;
    bool hasIds() const { return ids_ != 0; }
    /// Copies the colour buffer to the window's default framebuffer (same
    /// size or scaled), for windows whose default framebuffer is not sRGB.
    void blitToDefault(int width, int height) const;

    int width() const { return width_; }
    int height() const { return height_; }
    uint32_t framebuffer() const { return fbo_; }

private:
    OffscreenTarget() = default;
    void setDrawBuffers() const;
    int width_ = 0, height_ = 0;
    uint32_t fbo_ = 0, colour_ = 0, depth_ = 0, ids_ = 0;
};

/// Binds the window's default framebuffer for drawing, viewport (0, 0, w, h).
void bindDefaultFramebuffer(int width, int height);

/// A node layer's geometry on the GPU. A plain handle: free it with
/// GlRenderer::release; copying it copies the handle, not the buffers.
struct GpuMesh {
    uint32_t vao = 0, vbo = 0, ibo = 0;
    uint32_t vertex_count = 0, index_count = 0;
    uint32_t index_type = 0;          ///< GL_UNSIGNED_SHORT up to 65536 vertices, else GL_UNSIGNED_INT
    bool has_uv_atlas = false, has_uv_original = false, has_material_id = false, has_feature_id = false;
    std::vector<MeshData::TextureRange> texture_ranges;  ///< leaves: per original texture (MeshData's)
    uint64_t gpu_bytes = 0;           ///< vertex + index buffer bytes
    bool valid() const { return vao != 0; }
};

/// A texture on the GPU (an atlas or a leaf's original). A plain handle like GpuMesh.
struct GpuTexture {
    uint32_t id = 0;
    int width = 0, height = 0;
    int channels = 3;                 ///< 3: BC1, 4: BC3, 1: BC4 (a computed texture; never decoded on the CPU)
    int levels = 0;
    bool wrap = false;                ///< GL_REPEAT (true) or GL_CLAMP_TO_EDGE
    bool decoded_on_cpu = false;      ///< uploaded as RGBA8 after tiles::decodeBc
    uint64_t gpu_bytes = 0;           ///< bytes of every level as stored on the GPU
    bool valid() const { return id != 0; }
};

/// What one frame did (endFrame).
struct FrameStats {
    uint32_t draw_calls = 0;
    uint32_t texture_binds = 0;  ///< texture binds actually issued (a bind of the texture already bound is skipped)
    uint32_t triangles = 0;
    uint32_t nodes = 0;          ///< node layers drawn: one per drawAtlas / drawOriginals / drawDummy call
    /// Wall time spent in upload() since the previous endFrame, milliseconds
    /// (CPU time of the GL calls, which on llvmpipe includes the copy).
    double gpu_upload_ms = 0;
    uint64_t upload_bytes = 0;   ///< GPU bytes uploaded since the previous endFrame
};

struct RendererOptions {
    /// Test hook: decode BC1/BC3 on the CPU even when the context samples
    /// S3TC, to compare both paths (see GlRenderer::decodesOnCpu).
    bool force_cpu_decode = false;
    /// Upper bound of anisotropic filtering (clamped to what the context offers).
    float max_anisotropy = 16;
};

class GlRenderer {
public:
    /// The dummy texture's colour (sRGB bytes, opaque), drawn by drawDummy.
    static constexpr std::array<uint8_t, 4> kDummyColour{200, 120, 40, 255};
    /// The colour of untextured vertices without a material (and of textured
    /// ones drawn without a texture), linear.
    static constexpr float kNeutralGrey = 0.7F;

    /// Compiles the shaders and makes the material table and dummy texture;
    /// needs a current OpenGL 3.3 core context. Fails (nullptr, one line
    /// naming the shader and the compiler's first message) on errors.
    static std::unique_ptr<GlRenderer> create(const std::vector<MaterialInfo>& materials, Status* status);
    static std::unique_ptr<GlRenderer> create(const std::vector<MaterialInfo>& materials,
                                              const RendererOptions& options, Status* status);
    ~GlRenderer();
    GlRenderer(const GlRenderer&) = delete;
    GlRenderer& operator=(const GlRenderer&) = delete;

    /// Uploads a mesh. Refuses (an invalid handle and a one-line reason in
    /// *status, when given) arrays of the wrong size, an index out of range, an
    /// index count not a multiple of 3, texture ranges outside the indices, or
    /// more than 2^32 - 1 vertices. An empty mesh gives an invalid handle and ok.
    GpuMesh upload(const MeshData& mesh, Status* status = nullptr);
    /// Uploads a BC1 (channels 3) / BC3 (channels 4) texture with every level it
    /// has, trilinear and anisotropic filtering, repeat (wrap) or clamp to edge.
    /// Without sRGB S3TC support the blocks are decoded on the CPU
    /// (tiles::decodeBc) and uploaded as RGBA8; decodesOnCpu() says so.
    /// Refuses (invalid handle, *status) sizes, levels or byte ranges that do
    /// not match the data.
    GpuTexture upload(const CompressedTexture& texture, bool wrap, Status* status = nullptr);
    void release(GpuMesh* mesh);
    void release(GpuTexture* texture);

    /// True when textures are decoded on the CPU (no sRGB S3TC in the context,
    /// or RendererOptions::force_cpu_decode): textures then take 4 bytes per
    /// texel (8x BC1, 4x BC3) on the GPU.
    bool decodesOnCpu() const { return cpu_decode_; }

    /// Starts a frame into the framebuffer bound now: viewport (0, 0,
    /// camera.width_px, camera.height_px), clear to `clear_linear` (linear RGBA)
    /// and depth 1. Draws are queued and issued by endFrame.
    void beginFrame(const Camera& camera, const std::array<float, 4>& clear_linear);
    /// Draws a node layer with its atlas (uv_atlas): textured vertices sample
    /// the atlas (nullptr: they get the neutral grey), vertices with a material
    /// id >= 0 get its colour. `layer` 0 is opaque, 1 is blended.
    /// `computed` (optional): the node layer's computed texture (BC4), shown
    /// as setComputed says on its textured vertices (sampled with uv_atlas).
    void drawAtlas(const GpuMesh& mesh, const GpuTexture* atlas, const Vec3d& node_centre, int layer,
                   const GpuTexture* computed = nullptr);
    /// Draws a leaf with its original textures: one bind and one draw per
    /// texture range; `original(texture)` gives the resident texture or nullptr,
    /// in which case that range is drawn with `atlas_fallback` and uv_atlas
    /// (nullptr too: colours only). Range -1 (untextured) draws material
    /// colours. A mesh without ranges (an inner node) draws as drawAtlas with
    /// atlas_fallback. `original` is called here, not at endFrame.
    void drawOriginals(const GpuMesh& mesh, const std::function<const GpuTexture*(int32_t texture)>& original,
                       const GpuTexture* atlas_fallback, const Vec3d& node_centre, int layer,
                       const GpuTexture* computed = nullptr);
    /// How computed textures show from the next endFrame on.
    void setComputed(const ComputedStyle& style) { computed_style_ = style; }
    /// Draws the whole mesh with one shared dummy texture (uv_atlas), materials
    /// ignored: the papers' upper bound with no texture switches.
    void drawDummy(const GpuMesh& mesh, const Vec3d& node_centre, int layer);
    /// The lenses from the next frame on (uploads the per-feature tables).
    void setLens(const LensStyle& lens);
    /// The lenses set now as a BlockMap draw applies them (its tables are this
    /// renderer's: valid until the next setLens).
    BlockMapLens blockMapLens() const;
    /// Screen-door cross-fade for the draw*() calls that follow (until the
    /// next setFade): 0 none; 1 fading in, 2 fading out, at `progress` in
    /// [0, 1]. A 4 x 4 ordered dither keeps a fading-in fragment where the
    /// pixel's threshold is below progress and a fading-out one where it is
    /// not, so a node fading in and the one it replaces fading out at the
    /// same progress cover each pixel exactly once between them.
    void setFade(int mode, float progress) {
        fade_mode_ = mode;
        fade_progress_ = progress;
    }
    /// Issues the queued draws: the opaque layer in call order with depth
    /// writes, then the alpha layer, far nodes first, blended (src alpha, one
    /// minus src alpha) with depth test on and depth writes off. Leaves
    /// GL_FRAMEBUFFER_SRGB and blending off. The meshes and textures passed to
    /// the draw calls must stay alive until here.
    FrameStats endFrame();
    /// Edge enhancement (render/gl/edge_pass.h) over the frame just ended in
    /// `target` (which needs an id buffer), with that frame's camera; nothing
    /// when `style` is off.
    Status applyEdges(const OffscreenTarget& target, const EdgeStyle& style);
    /// Waits until the GL has executed every command issued (glFinish): frame
    /// times then include the GPU's (llvmpipe's) work, not just the CPU's.
    void finish();

private:
    GlRenderer() = default;
    struct Draw {
        const GpuMesh* mesh = nullptr;
        const GpuTexture* texture = nullptr;  ///< nullptr: colours only
        const GpuTexture* computed = nullptr; ///< the node layer's computed texture, if shown
        int mode = 0;                          ///< shader mode (gl_renderer.cpp)
        bool uv_original = false;
        uint32_t first_index = 0, index_count = 0;
        int node = 0;                          ///< index of the draw*() call that queued it
    };
    struct NodeDraw {
        std::array<float, 3> offset{};         ///< node_centre - camera.position, rounded once
        double distance = 0;                   ///< |offset| in double, for the alpha order
        int layer = 0;
        int fade = 0;                          ///< setFade's mode and progress when it was queued
        float fade_progress = 0;
    };
    void queue(const GpuMesh& mesh, const GpuTexture* texture, int mode, bool uv_original, uint32_t first,
               uint32_t count, const GpuTexture* computed = nullptr);
    int beginNode(const Vec3d& node_centre, int layer);
    void issue(const Draw& draw, FrameStats* stats);

    RendererOptions options_;
    bool cpu_decode_ = false;
    bool anisotropic_ = false;
    float anisotropy_ = 1;
    uint32_t program_ = 0;
    int u_view_projection_ = -1, u_offset_ = -1, u_uv_set_ = -1, u_mode_ = -1, u_opaque_ = -1,
        u_texture_ = -1, u_materials_ = -1, u_material_count_ = -1, u_pass_ = -1, u_fade_ = -1, u_fade_t_ = -1;
    LensStyle lens_;
    bool any_xray_ = false;
    int fade_mode_ = 0;
    float fade_progress_ = 0;
    uint32_t style_buffer_ = 0, style_texture_ = 0, base_buffer_ = 0, base_texture_ = 0, tint_buffer_ = 0,
             tint_texture_ = 0;
    uint32_t material_buffer_ = 0, material_texture_ = 0;
    int material_count_ = 0;
    GpuTexture dummy_;
    ComputedStyle computed_style_;
    uint32_t ramp_texture_ = 0;     ///< 256 x 1 sRGB, computedRamp()
    uint32_t bound_computed_ = 0;   ///< on unit 5, as far as this frame knows
    int u_computed_mode_ = -1;

    Camera camera_;
    std::unique_ptr<EdgePass> edges_;  ///< made on the first applyEdges
    std::vector<Draw> draws_;
    std::vector<NodeDraw> nodes_;
    uint32_t bound_texture_ = 0;  ///< on unit 0, as far as this frame knows
    double upload_ms_ = 0;
    uint64_t upload_bytes_ = 0;
};

}  // namespace cityatlas::render
