// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// A sharded build (issue 17): plan, independent shard jobs, merge.
///
/// - **plan** (writePlan): the whole scene's GlobalDecisions (d_min, its
///   enlargement for critical triangles, promotions), the tileset texture
///   numbering and the top cuts (atlas/shard_plan.h); writes the plan folder:
///   `plan.json` (parameters, decisions, the top, the build's directory),
///   `tables.json` (materials, georeference), `textures.bin` (the textures
///   and their file digests, binary), `texture_plan.bin` (per texture its
///   tileset number and promotion, binary) and `shard-<k>.tri` (the shard's triangles, in
///   scene order), and the feature tables into the build's folder. The input
///   is read once into a spill file (PlanSink); the plan passes over that
///   file, so no step holds every triangle.
/// - **shard k** (runShard): builds shard k's subtree completely, atlases and
///   geometry, in `shard-<k>/` (written as `shard-<k>.part/`, renamed when
///   complete): its node files named by the subtree's own numbering, and
///   `manifest.json` with its nodes, their tileset records, the root's
///   geometry and halved atlases for the levels above.
/// - **reuse** (reuseShards): a rebuild links in the previous build's shards
///   whose content key (triangles, parameters, d_min, level, the textures'
///   and materials' entries and file contents) is unchanged.
/// - **merge** (mergeShards): the whole tree from the top and the manifests,
///   the top's atlases (the shard roots' halves placed) and geometry (merged
///   and simplified), every shard file renamed to its node's number in the
///   whole tree, the original-texture blocks, the feature tables and
///   tileset.json.
///
/// Each step reads only what the plan folder holds, so shards can run in
/// this process, in local worker processes or as cluster jobs, with
/// byte-identical results.

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "atlas/atlas_tree.h"
#include "atlas/computed_spec.h"
#include "atlas/shard_plan.h"
#include "cli/build_hash.h"
#include "core/record_file.h"
#include "core/resource_usage.h"
#include "core/status.h"
#include "ingest/diagnostics.h"
#include "ingest/feature_spill.h"
#include "ingest/procedural_facades.h"
#include "ingest/scene.h"
#include "ingest/scene_sink.h"
#include "tiles/feature_bounds.h"
#include "tiles/tileset.h"

namespace cityatlas::cli {

using ShardProgressFn = std::function<void(const char* step, uint64_t done, uint64_t total)>;

/// Reading straight into a plan: the triangles go to a spill file as they
/// come, in scene order, and the features to another (ingest/feature_spill.h);
/// the tables (textures, materials, georeference) stay in memory, and what
/// the plan needs of each feature (its summary and bounds, 96 bytes) while
/// its triangles come: older features' wait in scratch files beside the spill.
class PlanSink : public SceneCollector {
public:
    PlanSink(std::filesystem::path spill, std::filesystem::path feature_spill);
    // SceneCollector::scene holds the tables (textures, materials, georeference), never triangles or features.
    FeatureSpill feature_spill;
    atlas::FeatureSummaries features;
    tiles::FeatureBoundsAccumulator bounds;  ///< for the feature tables (features/bounds/<k>.bin)
    SceneStatsAccumulator stats;
    uint64_t triangles = 0;
    Status finish();                   ///< closes the spills; an error when a write failed
    void addTriangles(std::vector<Triangle>& t) override;
    uint32_t addFeature(Feature f) override { return feature_spill.add(f); }
    void setFeatureLod(uint32_t feature, int8_t lod) override { feature_spill.setLod(feature, lod); }

private:
    std::filesystem::path spill_;
    std::ofstream file_;
};

/// Every triangle of a spill file, in order (a chunk in memory at a time);
/// bytes read go to `progress` as `step`.
Status forEachSpilled(const std::filesystem::path& spill, const std::function<void(const Triangle&)>& fn,
                      const char* step = nullptr, const ShardProgressFn& progress = {});
/// The whole spill file in memory (a build of one shard in this process).
Status readSpill(const std::filesystem::path& spill, std::vector<Triangle>* out);
/// Procedural facades (ingest/procedural_facades.h) over a spilled read:
/// one pass for each feature's walls' extent, the attributes from
/// `features`, the palettes' cells written as PNG into `dir` and added to
/// `tables`' textures, and a second pass rewriting `spill` with every bare
/// wall textured; `bounds` sees the rewritten triangles again (their
/// features are textured now). `walls` counts the triangles textured.
Status addProceduralFacades(const std::filesystem::path& spill, const FeatureSpill& features,
                            const ProceduralFacadeParams& params, const std::filesystem::path& dir, Scene* tables,
                            tiles::FeatureBoundsAccumulator* bounds, uint64_t* walls);
/// What addStylisedFacades did with the scene's textures.
struct StylisedFacadeCounts {
    uint64_t stylised = 0;         ///< replaced by their stylised facade
    uint64_t without_windows = 0;  ///< of those, with no window grid (one colour), tilted ones included
    uint64_t tilted = 0;           ///< of those, not upright on their walls: their colour only
    uint64_t not_facades = 0;      ///< also on roofs or the ground (an atlas, paving): kept
    uint64_t unreadable = 0;       ///< kept; the atlas stage reports them
    std::vector<std::string> photos;  ///< the paths of the textures replaced, in texture order
};
/// Stylised facades (ingest/stylised_facades.h) over a spilled read: every
/// texture that only walls use is analysed, drawn again as its stylised
/// facade (same size and channels) into `dir` as PNG, and `tables`' entry
/// points there; triangles and uvs are unchanged. The window grid is kept
/// only where the texture stands upright on its walls (world up along the
/// image's columns within 10 degrees, over 90 % of their area): a tilted
/// crop (oblique aerial texturing) gets its facade colour alone.
Status addStylisedFacades(const std::filesystem::path& spill, const std::filesystem::path& dir, Scene* tables,
                          StylisedFacadeCounts* counts);
/// decideGlobals over the spilled scene: two passes over the file, more when
/// its texture models exceed their budget (atlas_tree.h).
Status decideGlobalsFromSpill(const std::filesystem::path& spill, const Scene& tables, const atlas::AtlasParams& params,
                              atlas::GlobalDecisions* out, const ShardProgressFn& progress = {});

/// Writes the plan folder `dir` (created) for the scene of `tables` and the
/// `spill` file; `feature_tables` were written into the build's folder
/// already (they need nothing of the tree, and the features go before the
/// plan's passes). `texture_digests` (aligned with the scene's textures) are
/// kept with them (textures.bin) and enter the shards' content keys (`keys`,
/// also in plan.json).
///
/// With computed textures (`computed`, issue 19) each shard also gets
/// `shard-<k>.occ`: the other shards' triangles (positions) that come within
/// occluderMargin(the largest horizon) of its box, so a shard's rays meet every triangle
/// the whole scene would put within the horizon, and its computed textures
/// do not depend on the sharding.
Status writePlan(const std::filesystem::path& dir, const Scene& tables, const std::filesystem::path& spill,
                 const atlas::ShardPlan& plan, const atlas::GlobalDecisions& globals,
                 const atlas::AtlasParams& atlas_params, const tiles::TilesParams& tiles_params,
                 const std::vector<atlas::ComputedSpec>& computed,
                 const DigestAt& texture_digest, const tiles::FeatureTables& feature_tables,
                 std::vector<std::string>* keys, const ShardProgressFn& progress = {});

/// The margin beyond the horizon within which other shards' triangles are
/// given to a shard as occluders (writePlan): border texels of a chart stand
/// for points up to a few texels outside their triangles.
inline double occluderMargin(double horizon_m) { return horizon_m + std::max(50.0, 0.05 * horizon_m); }

/// Where a sharded build keeps its shards, by content key, inside its folder
/// (hard links to the folder's own files, plus each shard's manifest, root
/// geometry and halved root atlases): the next build of the folder reuses
/// every shard whose key is unchanged.
inline constexpr const char* kShardCache = ".cityatlas-cache/shards";
/// Where it keeps its original-texture blocks by content key (tiles::BlockCache).
inline constexpr const char* kBlockCache = ".cityatlas-cache/blocks";
/// A shard's atlases as PNG (TilesParams::atlas_png), beside its files; in the
/// plan folder, the whole tree's, for the 3D Tiles export after the merge.
inline constexpr const char* kAtlasPngFolder = "png";

/// Incremental rebuilds: every shard of the plan in `dir` whose key has a
/// finished shard in `cache` (a previous build's kShardCache) is linked into
/// place instead of being built again; `reused` lists them.
Status reuseShards(const std::filesystem::path& dir, const std::filesystem::path& cache, std::vector<int>* reused);

/// Makes `plan` absolute and changes into the directory the build ran in
/// (plan.json's working_directory), where its relative input, texture and
/// output paths start: a shard or merge job run from anywhere else (a hand-run
/// job, `sbatch --chdir`) would otherwise find no textures. An error names the
/// directory when it does not exist on this machine.
Status enterBuildDirectory(std::string* plan);

/// The shards of the plan in `dir` not finished yet.
std::vector<int> shardsToBuild(const std::filesystem::path& dir);

/// Builds shard `shard` of the plan in `dir`; `threads` 0 = all cores.
Status runShard(const std::filesystem::path& dir, int shard, int threads, const ShardProgressFn& progress);

/// Runs every shard of the plan in `dir`: in this process (`workers` 0), or
/// in up to `workers` worker processes (`cityatlas shard`) side by side, each
/// with its share of the cores.
Status runShards(const std::filesystem::path& dir, int workers, int threads, const ShardProgressFn& progress);
/// Replaces this process (exec of this executable) with `cityatlas merge DIR
/// --run-shards --workers W --threads T [--quiet]`, which finishes the build
/// from DIR/build.json; returns only when the exec failed.
Status execMergeRunningShards(const std::filesystem::path& dir, int workers, int threads, bool quiet);

struct MergeResult {
    Scene tables;               ///< textures, materials, georeference (no triangles, no features)
    RecordFile<TextureDigest> texture_digests;   ///< aligned with tables.textures, in a scratch file beside the plan
    uint64_t scene_triangles = 0;
    atlas::AtlasTree tree;      ///< the whole tree, without triangles; stats summed over the shards
    tiles::TilesStats tiles;
    uint64_t shards = 0;
    /// The shards' own costs: wall and CPU seconds summed over them (their
    /// work, wherever it ran), peak memory the largest shard's.
    StageCost shard_cost;
    uint64_t blocks_reused = 0, blocks_encoded = 0;  ///< original-texture blocks
    /// What the 3D Tiles export needs besides the folder (tiles3d_writer.h).
    tiles::TilesParams tiles_params;
    tiles::TextureIndex texture_index;
    std::vector<std::vector<int32_t>> leaf_textures, leaf_tiles;
    /// With tiles_params.atlas_png: the whole tree's atlas PNGs (the plan folder's kAtlasPngFolder).
    std::filesystem::path atlas_png_dir;
};

/// Merges the finished shards of the plan in `dir` into the tile folder
/// `out_dir`. Original-texture blocks whose content (textures, their file
/// digests from the plan, the BC quality) a previous build of the folder kept in
/// `previous_cache` (its kBlockCache; empty: none) are linked, not encoded.
Status mergeShards(const std::filesystem::path& dir, const std::filesystem::path& out_dir,
                   const std::string& build_hash, Diagnostics& diagnostics, const ShardProgressFn& progress,
                   MergeResult* result, const std::filesystem::path& previous_cache = {});

struct SlurmJobs {
    std::string shards, merge;  ///< job ids
};

/// Submits the plan in `dir` to Slurm: the shards as one job array (each task
/// `cityatlas shard DIR --index $SLURM_ARRAY_TASK_ID`), the merge as a job that
/// runs after every task succeeded (`cityatlas merge DIR`; cancelled when one
/// fails). `sbatch_args` go to both sbatch calls; logs to `logs`. With
/// `wait`, returns when the merge job ends, an error when it failed.
Status submitSlurm(const std::filesystem::path& dir, int shards, const std::vector<std::string>& sbatch_args,
                   const std::filesystem::path& logs, bool wait, SlurmJobs* jobs);

/// Counted warnings as JSON (code, count, first examples), and back: the
/// counts add up into `diagnostics`, the examples kept are the first.
nlohmann::json diagnosticsToJson(const Diagnostics& diagnostics);
void addDiagnostics(const nlohmann::json& warnings, Diagnostics& diagnostics);

}  // namespace cityatlas::cli
