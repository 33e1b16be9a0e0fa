// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/atlas_report.h"

#include <algorithm>

#include "cityatlas_version.h"
#include "ingest/ingest_report.h"

namespace cityatlas::atlas {

using json = nlohmann::ordered_json;

double leafCoverage(const NodeLayer& layer) {
    const double area = static_cast<double>(layer.width) * layer.height;
    return area > 0 ? std::min(1.0, static_cast<double>(layer.packed_texels) / area) : 0.0;
}

json dminCandidatesJson(const DminChoice& choice) {
    json a = json::array();
    for (const auto& c : choice.candidates)
        a.push_back({{"d_m", c.d_m}, {"ratio", c.ratio}, {"originals_within_d_min_mb", c.originals_within_mb}});
    return a;
}

json texelBudgetJson(const TexelBudget& b) {
    return {{"content_required", b.content_required}, {"content_native", b.content_native}, {"repeats", b.repeats},
            {"borders", b.borders},   {"rounding", b.rounding},   {"empty", b.empty},
            {"inner", b.inner},       {"total", b.total()}};
}

json byteBudgetJson(const ByteBudget& b) {
    return {{"atlases", b.atlases},
            {"originals_used", b.originals_used},
            {"originals_needed", b.originals_needed},
            {"ratio", b.ratio()}};
}

json atlasParamsJson(const AtlasParams& p) {
    return {{"d_min_m", p.d_min_m ? json(*p.d_min_m) : json(nullptr)},
            {"d_min_from_data", p.d_min_from_data},
            {"d_min_diagonal_fraction", p.d_min_diagonal_fraction},
            {"atlas_size_px", p.atlas_size_px},
            {"border_px", p.border_px},
            {"screen_width_px", p.screen_width_px},
            {"screen_height_px", p.screen_height_px},
            {"vertical_fov_deg", p.vertical_fov_deg},
            {"filter", filterName(p.filter)},
            {"packing", packingMethodName(p.packing)},
            {"unique_charts", p.unique_charts},
            {"critical_fraction", p.critical_fraction},
            {"threads", p.threads},
            {"cache_mb", p.cache_mb}};
}

json makeAtlasReport(const AtlasTree& tree, const Scene& scene, const Diagnostics& diagnostics) {
    const AtlasParams& p = tree.params;
    const AtlasStats& s = tree.stats;
    json j;
    j["cityatlas_version"] = kCityAtlasVersion;
    j["kind"] = "atlas_report";
    j["parameters"] = atlasParamsJson(p);
    j["projection"] = {{"focal_px", tree.projection.focal_px},
                       {"corner_factor", tree.projection.corner_factor},
                       {"pixels_per_metre_at_d_min", tree.projection.pixelsPerMetreAt1m() / s.d_min_used_m}};
    j["d_min"] = {{"requested_m", s.d_min_requested_m},
                  {"used_m", s.d_min_used_m},
                  {"enlarged", s.d_min_used_m > s.d_min_requested_m},
                  {"scene_diagonal_m", s.scene_diagonal_m},
                  {"d_full_m", s.d_full_m},
                  {"d_first_upsampled_m", s.d_first_upsampled_m},
                  {"textures_upsampled", s.textures_upsampled},
                  {"textures_exact", s.textures_exact},
                  {"textures_needing_originals", s.textures_needing_originals},
                  {"chosen_by", {{"rule", s.d_min_choice.rule},
                                 {"reason", s.d_min_choice.reason},
                                 {"estimated_ratio", s.d_min_choice.estimated_ratio},
                                 {"originals_within_d_min_mb", s.d_min_choice.originals_within_m_mb},
                                 {"candidates", dminCandidatesJson(s.d_min_choice)}}}};
    j["critical_triangles"] = {{"at_requested_d_min", s.critical_triangles},
                               {"allowed_fraction", p.critical_fraction},
                               {"at_used_d_min", s.critical_after_enlarge},
                               {"split", s.triangles_split},
                               {"triangles_added", s.triangles_added_by_split},
                               {"enlarged_for_split_budget", s.enlarged_for_split_budget}};
    j["scene"] = {{"triangles", scene.triangles.size()},
                  {"textured_triangles", s.textured_triangles},
                  {"degenerate_uv_triangles", s.degenerate_uv_triangles},
                  {"textures", scene.textures.size()}};

    double min_cov = 1, sum_cov = 0;
    uint64_t leaf_layers = 0;
    json nodes = json::array();
    for (size_t id = 0; id < tree.nodes.size(); ++id) {
        const AtlasNode& n = tree.nodes[id];
        json layers = json::object();
        for (int l = 0; l < kLayerCount; ++l) {
            const NodeLayer& nl = n.layers[l];
            if (nl.range.count == 0) continue;
            json o = {{"first", nl.range.first}, {"count", nl.range.count},
                      {"atlas", nl.atlas_path.empty() ? json(nullptr) : json(nl.atlas_path)}};
            if (nl.present()) {
                o["size"] = {nl.width, nl.height};
                o["offset"] = {nl.offset[0], nl.offset[1]};
            }
            if (n.leaf() && nl.present()) {
                const double c = leafCoverage(nl);
                o["regions"] = nl.regions.size();
                o["coverage"] = c;
                min_cov = std::min(min_cov, c), sum_cov += c, ++leaf_layers;
            }
            layers[std::string(layerName(static_cast<Layer>(l)))] = std::move(o);
        }
        nodes.push_back({{"id", id},
                         {"parent", n.parent},
                         {"level", n.level},
                         {"children", n.children},
                         {"bounds", {{"min", {n.bounds.min.x, n.bounds.min.y, n.bounds.min.z}},
                                     {"max", {n.bounds.max.x, n.bounds.max.y, n.bounds.max.z}}}},
                         {"min_distance_m", n.min_distance_m},
                         {"sharp_from_m", n.sharp_from_m},
                         {"originals", n.originals.size()},
                         {"layers", std::move(layers)}});
    }
    j["tree"] = {{"nodes", s.nodes},
                 {"leaves", s.leaves},
                 {"depth", s.depth},
                 {"atlases", s.atlases},
                 {"triangles", tree.triangles.size()},
                 {"leaves_below_resolution", s.leaves_below_resolution},
                 {"coverage",
                  {{"overall", s.leaf_atlas_texels ? static_cast<double>(s.packed_texels) / s.leaf_atlas_texels : 0.0},
                   {"leaf_min", leaf_layers ? min_cov : 0.0},
                   {"leaf_mean", leaf_layers ? sum_cov / leaf_layers : 0.0}}}};
    j["texels"] = {{"original_texture_bytes", s.original_texture_bytes},
                   {"atlas_texture_bytes", s.atlas_texture_bytes},
                   {"packed_texels", s.packed_texels},
                   {"leaf_atlas_texels", s.leaf_atlas_texels},
                   {"textures_unreadable", s.textures_unreadable},
                   {"budget", texelBudgetJson(s.texels)}};
    j["bytes"] = byteBudgetJson(s.bytes);
    j["warnings"] = warningsJson(diagnostics);
    j["warnings_total"] = diagnostics.total();
    json steps = json::array();
    for (const StepStats& st : s.steps)
        steps.push_back({{"name", st.name}, {"seconds", st.seconds}, {"cpu_seconds", st.cpu_seconds}, {"peak_rss_mb", st.peak_rss_mb}});
    j["steps"] = std::move(steps);
    j["nodes"] = std::move(nodes);
    return j;
}

}  // namespace cityatlas::atlas
