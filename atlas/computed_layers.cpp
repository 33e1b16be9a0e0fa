// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/computed_layers.h"

#include <cmath>
#include <memory>

#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <fmt/format.h>

#include "atlas/atlas_images.h"
#include "atlas/sky_view.h"
#include "atlas/sun_hours.h"

namespace cityatlas::atlas {
namespace fs = std::filesystem;

namespace {

// The sun's directions in the scene's frame for a sun model.
Status sunDirections(const ComputedSpec& spec, const Georeference& georef, std::vector<Vec3d>* out) {
    const std::optional<SunFrame> frame = sunFrame(georef);
    if (!frame)
        return Status::Usage(fmt::format("--computed {}: the scene has no georeference (a local engineering CRS), so no "
                                         "sun; give --crs",
                                         spec.name()));
    std::vector<Vec3d> enu;
    if (spec.model == ComputedModel::SunHours) {
        SunSchedule s;
        s.latitude_deg = frame->latitude_deg, s.longitude_deg = frame->longitude_deg;
        s.year = spec.year, s.days = spec.days, s.step_minutes = spec.step_minutes;
        enu = daylightSunDirections(s);
    } else {
        SunDisc disc = spec.disc;
        if (!spec.time_utc.empty()) {
            const Vec3d d = sunDirectionEnu(frame->latitude_deg, frame->longitude_deg, *julianDayUtc(spec.time_utc));
            if (!(d.z > 0))
                return Status::Usage(fmt::format("--computed shadow: at {} UTC the sun is below the horizon at {:.4f}, {:.4f}",
                                                 spec.time_utc, frame->latitude_deg, frame->longitude_deg));
            disc.azimuth_deg = std::atan2(d.x, d.y) * 180.0 / M_PI;
            disc.elevation_deg = std::asin(std::clamp(d.z, -1.0, 1.0)) * 180.0 / M_PI;
        }
        enu = sunDiscDirections(disc);
    }
    out->clear();
    for (const Vec3d& d : enu) out->push_back(frame->toLocal(d));
    return Status::Ok();
}

}  // namespace

Status makeSurfaceField(const ComputedSpec& spec, const RayCaster& caster, const Georeference& georef, SurfaceField* out,
                        const VisibilityTarget* target) {
    const double far = spec.horizon_m;
    if (spec.model == ComputedModel::Visibility) {
        if (!target) return Status::Invalid(fmt::format("--computed visibility:{}: no target given", spec.building));
        *out = [target](const TexelSurface& s) { return visibilityRatio(*target, s.point, s.normal); };
        return Status::Ok();
    }
    if (spec.model == ComputedModel::SkyView) {
        auto dirs = std::make_shared<const std::vector<Vec3d>>(hemisphereDirections(spec.directions));
        *out = [&caster, dirs, far](const TexelSurface& s) { return skyViewFactor(caster, s.point, s.normal, *dirs, far); };
        return Status::Ok();
    }
    auto sun = std::make_shared<std::vector<Vec3d>>();
    if (Status s = sunDirections(spec, georef, sun.get()); !s.ok()) return s;
    *out = [&caster, sun, far](const TexelSurface& s) { return sunHoursFraction(caster, s.point, s.normal, *sun, far); };
    return Status::Ok();
}

void ComputedStats::add(const ScalarImage& image) {
    for (float v : image.value) {
        if (std::isnan(v)) continue;
        ++texels, sum += v;
        min = std::min(min, static_cast<double>(v)), max = std::max(max, static_cast<double>(v));
    }
}

void ComputedStats::add(const ComputedStats& o) {
    texels += o.texels, sum += o.sum;
    min = std::min(min, o.min), max = std::max(max, o.max);
}

Status computeTreeImages(const AtlasTree& tree, int scale, const SurfaceField& field, int threads,
                         const ComputedImageSink& sink, const GivenComputed* given,
                         std::array<ScalarImage, kLayerCount>* root, ComputedStats* stats) {
    if (tree.nodes.empty()) return Status::Ok();
    // Post-order, sibling subtrees side by side (a shard's leaves are many and
    // small: parallel rays within one leaf alone left a core idle): a node's
    // images are made once its children's are, which are then dropped. Leaf
    // statistics are kept per node and summed in node order at the end, so
    // they do not depend on the threads either.
    std::vector<ComputedStats> leaf_stats(stats ? tree.nodes.size() : 0);
    std::function<Status(int32_t, std::array<ScalarImage, kLayerCount>*)> visit =
        [&](int32_t n, std::array<ScalarImage, kLayerCount>* images) -> Status {
        const AtlasNode& node = tree.nodes[static_cast<size_t>(n)];
        if (given) {
            if (const auto it = given->find(n); it != given->end()) {
                *images = it->second;
                return Status::Ok();
            }
        }
        if (node.leaf()) {
            for (int l = 0; l < kLayerCount; ++l) {
                const auto layer = static_cast<Layer>(l);
                if (!node.layers[static_cast<size_t>(l)].present()) continue;
                const LeafTexelMap map = leafTexelMap(tree, n, layer, scale);
                ScalarImage& img = (*images)[static_cast<size_t>(l)];
                img = evaluateComputed(map, field, 0, kNoValue);  // in this arena, beside the other subtrees
                if (stats) leaf_stats[static_cast<size_t>(n)].add(img);
                if (Status s = sink(n, layer, img); !s.ok()) return s;
            }
            return Status::Ok();
        }
        std::array<std::array<ScalarImage, kLayerCount>, 4> children;
        std::array<Status, 4> results{Status::Ok(), Status::Ok(), Status::Ok(), Status::Ok()};
        tbb::task_group group;
        for (size_t q = 0; q < 4; ++q)
            if (node.children[q] >= 0) group.run([&, q] { results[q] = visit(node.children[q], &children[q]); });
        group.wait();
        for (const Status& r : results)
            if (!r.ok()) return r;
        for (int l = 0; l < kLayerCount; ++l) {
            const auto layer = static_cast<Layer>(l);
            if (!node.layers[static_cast<size_t>(l)].present()) continue;
            ScalarImage& img = (*images)[static_cast<size_t>(l)];
            img = innerComputed(tree, n, layer, scale, [&](int32_t c) -> const ScalarImage* {
                for (size_t q = 0; q < 4; ++q)
                    if (node.children[q] == c) return &children[q][static_cast<size_t>(l)];
                return nullptr;
            });
            if (Status s = sink(n, layer, img); !s.ok()) return s;
        }
        return Status::Ok();
    };
    std::array<ScalarImage, kLayerCount> top;
    Status result = Status::Ok();
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] { result = visit(0, &top); });
    if (!result.ok()) return result;
    if (stats)
        for (const ComputedStats& s : leaf_stats) stats->add(s);
    if (root) *root = std::move(top);
    return Status::Ok();
}

Status writeScalarImage(const ScalarImage& image, const fs::path& path) {
    return writeFloatImage(path, image.width, image.height, image.value);
}

Status readScalarImage(const fs::path& path, ScalarImage* out) {
    return readFloatImage(path, 1, true, "a computed image", &out->width, &out->height, &out->value);
}

}  // namespace cityatlas::atlas
