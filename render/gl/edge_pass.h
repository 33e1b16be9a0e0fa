// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Edge enhancement (papers/000 §5.2, illustrative rendering; issue 19): a
/// pass over a finished frame that outlines buildings and their creases from
/// the id and depth buffers, so façades without photos (material colours,
/// procedural cells) still read as separate volumes.
///
/// A pixel that shows a feature is an edge pixel when
///  - one of its 4 neighbours shows another feature, or none (outlines), or
///  - along a row or a column, the second difference of 1 / eye depth over
///    it and its two neighbours exceeds `crease` times its own 1 / eye depth
///    (creases and steps: 1 / eye depth is affine in screen space over a
///    plane, so a flat surface at any slant gives none).
/// Its colour is multiplied by 1 - `strength` in linear light. Pixels
/// without a feature and the image border's outer row stay as they are.

#include <cstdint>
#include <memory>

#include "core/status.h"
#include "render/core/view.h"

namespace cityatlas::render {

class OffscreenTarget;

struct EdgeStyle {
    bool enabled = false;
    float strength = 0.5F;  ///< darkening at an edge pixel, 0..1 (linear light)
    float crease = 0.02F;   ///< the second difference of 1 / depth over 1 / depth that makes a crease
};

/// The pass's GL objects: a program and copies of the target's id and depth
/// buffers as textures (a renderbuffer cannot be sampled).
class EdgePass {
public:
    /// Fails (nullptr, one line) when its shaders do not build.
    static std::unique_ptr<EdgePass> create(Status* status);
    ~EdgePass();
    EdgePass(const EdgePass&) = delete;
    EdgePass& operator=(const EdgePass&) = delete;

    /// Darkens the edge pixels of `target`'s colour buffer; `camera` is the
    /// one its frame was drawn with (its near and far planes). Needs an id
    /// buffer (Unsupported without one). Leaves `target` bound.
    Status apply(const OffscreenTarget& target, const Camera& camera, const EdgeStyle& style);

private:
    EdgePass() = default;
    uint32_t program_ = 0, vao_ = 0, fbo_ = 0, ids_ = 0, depth_ = 0;
    int width_ = 0, height_ = 0;
};

}  // namespace cityatlas::render
