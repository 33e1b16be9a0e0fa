// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Computed textures over a whole atlas tree (issue 19): each node layer's
/// image of a ComputedSpec's field, leaves evaluated on their texel maps
/// (computed_texture.h) and inner nodes made of their children's images
/// halved, the way the photo atlases are made. The images go to a sink as
/// they are made (the tiles stage encodes them as BC4); only the images a
/// parent still waits for are held.

#include <array>
#include <functional>
#include <limits>
#include <map>

#include "atlas/atlas_tree.h"
#include "atlas/computed_spec.h"
#include "atlas/computed_texture.h"
#include "atlas/raycast.h"
#include "atlas/visibility.h"

namespace cityatlas::atlas {

/// The field a spec computes at a surface point, against `caster` (the
/// local frame), with rays cut at the spec's horizon. Sun models need the
/// scene's georeference (an error without one: a local engineering CRS has
/// no sun). Visibility needs its target (visibility.h; `caster` unused):
/// the caller sets its horizon.
using SurfaceField = std::function<double(const TexelSurface&)>;
Status makeSurfaceField(const ComputedSpec& spec, const RayCaster& caster, const Georeference& georef, SurfaceField* out,
                        const VisibilityTarget* target = nullptr);

/// Values over the texels that hold one in leaf images (a texel the photo
/// atlas packs), for tileset.json's statistics.
struct ComputedStats {
    uint64_t texels = 0;
    double min = std::numeric_limits<double>::infinity(), max = -std::numeric_limits<double>::infinity(), sum = 0;
    void add(const ScalarImage& leaf_image);
    void add(const ComputedStats& other);
    double mean() const { return texels ? sum / static_cast<double>(texels) : 0.0; }
};

/// Every node layer's image, bottom up, each handed to `sink` once made
/// (from several threads at once: sibling subtrees run side by side).
/// Nodes in `given` (a merge's shard roots) take those images instead of
/// their subtree's; other leaves are evaluated with `field` (on `threads`
/// threads, 0: all cores; the images and statistics do not depend on it).
/// `root` (optional) gets the root's images.
using ComputedImageSink = std::function<Status(int32_t node, Layer layer, const ScalarImage& image)>;
using GivenComputed = std::map<int32_t, std::array<ScalarImage, kLayerCount>>;
Status computeTreeImages(const AtlasTree& tree, int scale, const SurfaceField& field, int threads,
                         const ComputedImageSink& sink, const GivenComputed* given,
                         std::array<ScalarImage, kLayerCount>* root, ComputedStats* stats);

/// A computed image as floats, and back (a shard's root image for the merge).
Status writeScalarImage(const ScalarImage& image, const std::filesystem::path& path);
Status readScalarImage(const std::filesystem::path& path, ScalarImage* out);

}  // namespace cityatlas::atlas
