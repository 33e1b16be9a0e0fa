// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Drawing a BlockMap (format/blockmap.h; papers/002 §3.2): its box is
/// rasterised (front faces) and a fragment shader walks the cells from where
/// the pixel's ray enters it, as render/core/blockmap_ray.h does on the CPU
/// (the shader's twin and oracle): a DDA in grid units with space leaping on
/// the distance plane, the hit's colour from the roof plane or the side's
/// wall column, its depth written (gl_FragDepth) with the projection meshes
/// use (GlRenderer: camera-relative, viewRotation and projection of
/// render/core/view.h), so BlockMaps and meshes share one depth buffer. The
/// id buffer gets the building's feature id.
///
/// GL 3.3 core only: integer textures, texelFetch, buffer textures,
/// gl_FragDepth; Mesa llvmpipe runs it.

#include <cstdint>
#include <memory>
#include <span>

#include "core/status.h"
#include "format/blockmap.h"
#include "render/core/lenses.h"
#include "render/core/view.h"

namespace cityatlas::render {

/// A BlockMap's planes on the GPU. A plain handle: free it with
/// BlockMapPass::release.
struct GpuBlockMap {
    uint32_t cells = 0, dist = 0, roof = 0, walls = 0;    ///< textures
    uint32_t columns_buffer = 0, columns = 0;             ///< the column table (buffer texture, RGBA16UI: x, y, rows, base)
    uint32_t features_buffer = 0, features = 0;           ///< local -> feature id (buffer texture, R32UI)
    int nx = 0, ny = 0;
    double cell_m = 0;
    Vec3d origin{0, 0, 0};
    double z_hi = 0;
    uint64_t gpu_bytes = 0;
    bool valid() const { return cells != 0; }
};

/// The lenses (render/core/lenses.h) as a BlockMap draw applies them, from
/// GlRenderer::blockMapLens: the per-feature tables GlRenderer::setLens
/// uploaded (buffer textures; 0: none) and the lens style they were made
/// from. A building styled discard or x-ray is left out (the ray goes on
/// through its cells: x-ray's translucent faces are for the near field's
/// meshes), a flattened one is pressed to its base, tints and the context
/// of the analytic lens colour the hit as they colour meshes.
struct BlockMapLens {
    uint32_t styles = 0;             ///< GL_R8UI buffer texture: LensStyle::style
    uint32_t tints = 0;              ///< GL_RGBA32F buffer texture: LensStyle::tint
    const LensStyle* style = nullptr;  ///< flatten and the analytic lens; null: no lens
};

class BlockMapPass {
public:
    /// Compiles the shaders; needs a current OpenGL 3.3 core context.
    /// nullptr and a one-line reason when they do not compile.
    static std::unique_ptr<BlockMapPass> create(Status* status);
    ~BlockMapPass();
    BlockMapPass(const BlockMapPass&) = delete;
    BlockMapPass& operator=(const BlockMapPass&) = delete;

    /// Uploads the planes; `roof` (nx x ny) and `walls` (wall_width x
    /// wall_height) are sRGB RGB8, rows from y = 0, or empty: grey. Refuses
    /// (an invalid handle, *status) planes of the wrong size.
    GpuBlockMap upload(const format::BlockMap& blockmap, std::span<const uint8_t> roof, std::span<const uint8_t> walls,
                       Status* status);
    void release(GpuBlockMap* blockmap);

    /// Draws into the bound framebuffer (colour with GL_FRAMEBUFFER_SRGB as
    /// meshes, depth, ids at location 1) as `camera` sees it; depth test on;
    /// with `lens`, the lenses as BlockMapLens says; `fade` and `fade_t` as
    /// GlRenderer::setFade's mode and progress (the same screen door,
    /// screen_door.h).
    void draw(const GpuBlockMap& blockmap, const Camera& camera, const BlockMapLens* lens = nullptr, int fade = 0,
              float fade_t = 0);
    /// Test hook: the id buffer gets (cell index) * 8 + face (blockmap_ray.h's
    /// faces) of each hit instead of the feature id.
    void setCellIds(bool on) { cell_ids_ = on; }

private:
    BlockMapPass() = default;
    uint32_t program_ = 0, vao_ = 0, vbo_ = 0, ibo_ = 0;
    bool cell_ids_ = false;
};

}  // namespace cityatlas::render
