// SPDX-License-Identifier: GPL-3.0-or-later
// The ray caster's throughput on a synthetic town (issue 19's benchmark:
// rays per second and seconds per million surface points of the sky-view
// factor at N directions), at 1 thread and at every core; the error of
// 16..1,024 directions against 4,096 (the speed/accuracy trade); then the same
// field as a computed texture: the town's atlas tree (structure only, unique
// charts, --d-min 400 as benchmarks/build_scale.sh), its leaf texels at scale 2, the seconds per
// million computed texels through the texel -> surface map on a sample of
// leaves, and the computed atlases' BC4 bytes against the photo atlases'
// BC1/BC3 bytes (both with mips, every node). Not a test.
// Usage: raycast_bench BUILDINGS DIRECTIONS POINTS TEXELS OUT.json
//   TEXELS: computed texels to evaluate (whole leaves until at least that many; 0 skips the part)
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include "atlas/atlas_tree.h"
#include "atlas/computed_texture.h"
#include "atlas/raycast.h"
#include "atlas/sky_view.h"
#include "ingest/synth/town.h"

using namespace cityatlas;

int main(int argc, char** argv) {
    if (argc != 6) {
        std::fprintf(stderr, "usage: raycast_bench BUILDINGS DIRECTIONS POINTS TEXELS OUT.json\n");
        return 2;
    }
    const auto buildings = static_cast<uint32_t>(std::stoul(argv[1]));
    const int directions = std::stoi(argv[2]);
    const auto wanted = static_cast<size_t>(std::stoul(argv[3]));
    const auto texels_wanted = static_cast<uint64_t>(std::stoull(argv[4]));
    using Clock = std::chrono::steady_clock;
    const auto seconds = [](Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); };

    // The town of benchmarks/build_scale.sh BUILDINGS 400 (512 px facades, seed 1).
    synth::TownSettings s;
    s.buildings = buildings;
    s.texture_size_px = 512;
    s.seed = 1;
    const Scene scene = synth::townToScene(synth::generateTown(s), "/nonexistent");
    std::vector<std::array<Vec3d, 3>> tris;
    for (const Triangle& t : scene.triangles) tris.push_back(t.position_local);
    auto t0 = Clock::now();
    const auto caster = atlas::RayCaster::build(tris);
    const double build_s = seconds(t0);

    // Surface points: triangle centroids, spread over the whole town.
    std::vector<std::pair<Vec3d, Vec3d>> points;
    const size_t step = std::max<size_t>(1, tris.size() / wanted);
    for (size_t i = 0; i < tris.size() && points.size() < wanted; i += step) {
        const auto& p = tris[i];
        const Vec3d n = cross(p[1] - p[0], p[2] - p[0]);
        if (!(length(n) > 0)) continue;
        points.emplace_back((1.0 / 3) * (p[0] + p[1] + p[2]), n);
    }
    const auto dirs = atlas::hemisphereDirections(directions);
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    std::string runs;
    for (const int threads : {1, cores}) {
        std::vector<double> svf(points.size());
        tbb::task_arena arena(threads);
        t0 = Clock::now();
        arena.execute([&] {
            tbb::parallel_for(size_t{0}, points.size(), [&](size_t i) {
                svf[i] = atlas::skyViewFactor(*caster, points[i].first, points[i].second, dirs);
            });
        });
        const double secs = seconds(t0);
        const double rays = static_cast<double>(points.size()) * directions;
        double mean = 0;
        for (const double v : svf) mean += v / static_cast<double>(svf.size());
        std::printf("%d thread(s): %zu points x %d directions in %.2f s: %.2f M rays/s, %.1f s per million points, mean SVF %.3f\n",
                    threads, points.size(), directions, secs, rays / secs / 1e6, secs / static_cast<double>(points.size()) * 1e6, mean);
        if (!runs.empty()) runs += ",";
        runs += "{\"threads\":" + std::to_string(threads) + ",\"seconds\":" + std::to_string(secs) +
                ",\"rays_per_second\":" + std::to_string(rays / secs) +
                ",\"seconds_per_million_points\":" + std::to_string(secs / static_cast<double>(points.size()) * 1e6) +
                ",\"mean_svf\":" + std::to_string(mean) + "}";
    }
    std::printf("%u buildings, %zu triangles: tree built in %.2f s\n", buildings, caster->triangles(), build_s);

    // The speed/accuracy trade of the direction count: the error against
    // 4,096 directions on 2,000 of the points, and the time per million points.
    std::string trade;
    {
        const size_t n_points = std::min<size_t>(points.size(), 2000);
        const auto reference_dirs = atlas::hemisphereDirections(4096);
        std::vector<double> reference(n_points);
        tbb::parallel_for(size_t{0}, n_points, [&](size_t i) {
            reference[i] = atlas::skyViewFactor(*caster, points[i].first, points[i].second, reference_dirs);
        });
        for (const int n : {16, 32, 64, 128, 256, 1024}) {
            const auto d = atlas::hemisphereDirections(n);
            std::vector<double> err(n_points);
            t0 = Clock::now();
            tbb::parallel_for(size_t{0}, n_points, [&](size_t i) {
                err[i] = std::abs(atlas::skyViewFactor(*caster, points[i].first, points[i].second, d) - reference[i]);
            });
            const double secs = seconds(t0);
            double mean = 0;
            for (const double e : err) mean += e / static_cast<double>(n_points);
            std::sort(err.begin(), err.end());
            const double p99 = err[static_cast<size_t>(0.99 * static_cast<double>(n_points - 1))], worst = err.back();
            std::printf("N = %4d: |SVF - SVF(4096)| mean %.4f, p99 %.4f, max %.4f (%.2f of an 8-bit step at p99); %.1f s per million points\n",
                        n, mean, p99, worst, p99 * 255, secs / static_cast<double>(n_points) * 1e6);
            if (!trade.empty()) trade += ",";
            trade += "{\"directions\":" + std::to_string(n) + ",\"mean_error\":" + std::to_string(mean) +
                     ",\"p99_error\":" + std::to_string(p99) + ",\"max_error\":" + std::to_string(worst) +
                     ",\"seconds_per_million_points\":" + std::to_string(secs / static_cast<double>(n_points) * 1e6) + "}";
        }
    }

    std::string computed = "null";
    if (texels_wanted > 0) {
        constexpr int kScale = 2;
        atlas::AtlasParams p;
        p.render_images = false;
        p.unique_charts = true;
        p.d_min_m = 400;  // as build_scale.sh's figures
        atlas::AtlasTree tree;
        Diagnostics diagnostics;
        t0 = Clock::now();
        if (Status st = atlas::buildAtlasTree(scene, p, {}, diagnostics, {}, &tree); !st.ok()) {
            std::fprintf(stderr, "atlas tree: %s\n", st.error.c_str());
            return 1;
        }
        const double tree_s = seconds(t0);
        uint64_t photo_bytes = 0, computed_bytes = 0, leaf_texels = 0;
        std::vector<int32_t> leaves;
        for (size_t n = 0; n < tree.nodes.size(); ++n)
            for (int l = 0; l < atlas::kLayerCount; ++l) {
                const atlas::NodeLayer& nl = tree.nodes[n].layers[static_cast<size_t>(l)];
                if (nl.width == 0) continue;
                photo_bytes += atlas::bcBytesWithMips(nl.width, nl.height, l == 0 ? 3 : 4);
                computed_bytes += atlas::bcBytesWithMips(nl.width / kScale, nl.height / kScale, 3);  // BC4: 8 bytes a block, as BC1
                if (tree.nodes[n].leaf()) {
                    leaf_texels += static_cast<uint64_t>(nl.width / kScale) * static_cast<uint64_t>(nl.height / kScale);
                    if (l == 0) leaves.push_back(static_cast<int32_t>(n));
                }
            }
        // Whole leaves spread over the town until enough texels.
        uint64_t texels = 0, surfaces = 0, evaluated = 0;
        double map_s = 0, eval_s = 0;
        const size_t stride = std::max<size_t>(1, leaves.size() / 64);
        for (size_t k = 0; k < leaves.size() && texels < texels_wanted; k += stride) {
            t0 = Clock::now();
            const atlas::LeafTexelMap map = atlas::leafTexelMap(tree, leaves[k], atlas::Layer::Opaque, kScale);
            map_s += seconds(t0);
            t0 = Clock::now();
            const atlas::ScalarImage img = atlas::evaluateComputed(
                map, [&](const atlas::TexelSurface& ts) { return atlas::skyViewFactor(*caster, ts.point, ts.normal, dirs); }, 0,
                atlas::kNoValue);
            eval_s += seconds(t0);
            texels += static_cast<uint64_t>(map.width) * static_cast<uint64_t>(map.height);
            surfaces += map.surfaces.size();
            ++evaluated;
        }
        const double per_million = (map_s + eval_s) / static_cast<double>(std::max<uint64_t>(texels, 1)) * 1e6;
        std::printf("atlas tree (structure, unique charts) in %.1f s: %zu nodes, %llu leaf texels at scale %d\n", tree_s,
                    tree.nodes.size(), static_cast<unsigned long long>(leaf_texels), kScale);
        std::printf("sky view as a computed texture: %llu texels (%llu standing for a surface) of %zu leaves in %.2f s "
                    "(map %.2f s): %.1f s per million texels, so %.0f s for every leaf texel on %d cores\n",
                    static_cast<unsigned long long>(texels), static_cast<unsigned long long>(surfaces),
                    static_cast<size_t>(evaluated), map_s + eval_s, map_s, per_million,
                    per_million * static_cast<double>(leaf_texels) / 1e6, cores);
        std::printf("bytes with mips, every node: photo atlases %.1f MB, computed (BC4, scale %d) %.1f MB (%.2f of photo)\n",
                    photo_bytes / 1e6, kScale, computed_bytes / 1e6, static_cast<double>(computed_bytes) / photo_bytes);
        computed = "{\"scale\":" + std::to_string(kScale) + ",\"tree_seconds\":" + std::to_string(tree_s) +
                   ",\"leaf_texels\":" + std::to_string(leaf_texels) + ",\"texels_evaluated\":" + std::to_string(texels) +
                   ",\"seconds_per_million_texels\":" + std::to_string(per_million) +
                   ",\"photo_atlas_bytes\":" + std::to_string(photo_bytes) +
                   ",\"computed_bytes\":" + std::to_string(computed_bytes) + "}";
    }
    std::ofstream out(argv[5]);
    out << "{\"benchmark\":\"raycast\",\"buildings\":" << buildings << ",\"triangles\":" << caster->triangles()
        << ",\"directions\":" << directions << ",\"points\":" << points.size() << ",\"build_seconds\":" << build_s
        << ",\"runs\":[" << runs << "],\"directions_trade\":[" << trade << "],\"computed\":" << computed << "}\n";
    return out ? 0 : 1;
}
