// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Per-texture economy over the whole scene: what a texture's atlas regions
/// cost at a distance d, and whether holding it exactly (every region at the
/// texture's own resolution) is cheaper than its original. The tree build
/// promotes such textures (so no original is written for them) and the
/// default d_min chooser estimates with the same model. Internal to the atlas stage.

#include <vector>

#include "atlas/atlas_tree.h"
#include "atlas/charts.h"

namespace cityatlas::atlas {

struct TextureModel {
    std::vector<ChartMember> members;  ///< every triangle of the texture, scene-wide
    NativeSize native;
    int channels = 3;
    double original_bytes = 0;         ///< BC with mips
    double x = 0, y = 0;               ///< centre of its triangles' bounds (local frame)
    /// Its regions held at full resolution: the same at every distance, so planned once.
    double full_texels = 0;
    bool full_exact = false;           ///< every such region is exact (no line of texture)
    bool full_fits = false;            ///< every triangle fits one atlas at full resolution
};

/// One model per scene texture (empty members for unused ones), built one
/// triangle at a time (inputs never held whole): 48 bytes a textured triangle
/// (and a vector's spare room while it grows) and kBytesPerTexture a texture.
/// A builder may take a range of textures only, [first, end), and ignore the
/// others' triangles (a city's models are built a range at a time: atlas_tree.h
/// decideGlobals); `reserve` gives each texture's triangle count when known.
/// finish() adds the full-resolution plans, in parallel on the current TBB arena,
/// and returns the range's models (index 0 = texture `first`).
class TextureModelBuilder {
public:
    TextureModelBuilder(size_t textures, double pixels_per_metre_at_1m);
    TextureModelBuilder(size_t first, size_t end, double pixels_per_metre_at_1m, const uint32_t* reserve = nullptr);
    void add(const Triangle& t);
    std::vector<TextureModel> finish(const TextureTable& textures, const AtlasParams& params);
    /// What the builder holds, in bytes: its members' vectors as allocated
    /// (with their growth's spare room) and each texture's model and box.
    uint64_t bytes() const { return capacity_ * sizeof(ChartMember) + m_.size() * kBytesPerTexture; }
    static constexpr uint64_t kBytesPerTexture = sizeof(TextureModel) + sizeof(Box3d);

private:
    double ppm_;
    size_t first_ = 0;
    uint64_t capacity_ = 0;  // members' vector capacities, summed
    std::vector<TextureModel> m_;
    std::vector<Box3d> bounds_;
};

struct TexturePlan {
    double region_texels = 0;  ///< its regions' area at d (promoted: at full resolution)
    bool exact = false;        ///< no original needed: every region capped on both axes, one colour, or promoted
    bool promoted = false;     ///< held at full resolution because that is cheaper than the original
};

/// Plans the texture's regions at distance `d` as one node would (charts.h),
/// and promotes it to full resolution when the extra atlas texels (with the
/// levels above, a third more) cost less than its original's texels. Regions
/// with a line of texture (no extent on an axis) cannot be promoted.
TexturePlan planTexture(const TextureModel& texture, const AtlasParams& params, double d);

}  // namespace cityatlas::atlas
