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
#include "core/status.h"
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

/// Where the candidates start (every texture capped on both axes below) and
/// where every texture is below its own resolution: over every textured
/// triangle's model member, its texels per metre at 1 m over its texture's size.
struct DminRange {
    double lo = 1e300, hi = 0;
    void add(const ChartMember& m, NativeSize native);
};

/// The scene's texture models a range at a time: calls its argument with
/// consecutive ranges of them, in texture order, covering every texture
/// (each call may be a pass over the input: atlas_tree.h decideGlobals).
using ModelBatches = std::function<Status(const std::function<void(const std::vector<TextureModel>&)>&)>;

/// estimateDminCandidates from models given in batches: the same estimates
/// to the bit. `range` over all the models. Candidates are estimated a few
/// per round of batches.
Status estimateDminCandidatesInBatches(const DminRange& range, const ModelBatches& batches, double diagonal_m,
                                       const AtlasParams& params, const std::function<bool(const DminEstimate&)>& enough,
                                       std::vector<DminEstimate>* out);

/// Picks d_min from the estimates by `rule`; without textures, the diagonal
/// fraction of `diagonal_m`. `textures`: the scene's TextureModelBuilder::finish(). Sets
/// *d_min_m and says why.
DminChoice chooseDefaultDmin(const std::vector<TextureModel>& textures, double diagonal_m, const AtlasParams& params,
                             double* d_min_m, const DminRule& rule = {});
/// The same from models given in batches.
Status chooseDefaultDminInBatches(const DminRange& range, const ModelBatches& batches, double diagonal_m,
                                  const AtlasParams& params, double* d_min_m, DminChoice* choice,
                                  const DminRule& rule = {});

}  // namespace cityatlas::atlas
