// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// The default d_min, chosen from the data (papers/000 §6.1.2, "Computing the
/// minimum distance value", made robust): for distances from d_full up to the
/// scene diagonal, estimate what the tree would cost,
///   ratio(d) = (atlases + the originals leaves still need) / (originals used),
/// all as BC with mips, and how many bytes of originals a camera needs within d
/// (the originals' rendering load, the thesis' first criterion). The choice is
/// the smallest d whose ratio is at most `ratio_target` with a load of at most
/// `originals_within_mb`; if none is, the cheapest d within the load bound.
/// The estimate plans every texture's regions as a node would (charts.h:
/// caps, merging), over the whole scene.

#include <functional>
#include <vector>

#include "atlas/atlas_tree.h"
#include "atlas/texture_economy.h"

namespace cityatlas::atlas {

struct DminRule {
    double ratio_target = 1.8;         ///< below the 2.0 the economy promise allows, for the estimate's error
    double originals_within_mb = 64;   ///< 1/8 of the client's default 512 MB budget
};

struct DminEstimate {
    double d_m = 0;
    double ratio = 0;
    double atlas_bytes = 0, originals_needed_bytes = 0, originals_used_bytes = 0;
    double originals_within_bytes = 0;  ///< the most any camera needs within d (estimated on a grid of d/4 cells)
};

/// The estimates at the candidate distances, ascending: from where every
/// texture is capped, by factors of sqrt 2, to 16 x past where none is and the
/// scene diagonal; with `enough`, stopping three candidates after the first it
/// accepts. Empty without textured triangles.
std::vector<DminEstimate> estimateDminCandidates(const std::vector<TextureModel>& textures, double diagonal_m,
                                                 const AtlasParams& params,
                                                 const std::function<bool(const DminEstimate&)>& enough = {});

/// Picks d_min from the estimates by `rule`; without textures, the diagonal
/// fraction of `diagonal_m`. `textures`: the scene's TextureModelBuilder::finish(). Sets
/// *d_min_m and says why.
DminChoice chooseDefaultDmin(const std::vector<TextureModel>& textures, double diagonal_m, const AtlasParams& params,
                             double* d_min_m, const DminRule& rule = {});

}  // namespace cityatlas::atlas
