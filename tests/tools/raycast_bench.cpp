// SPDX-License-Identifier: GPL-3.0-or-later
// The ray caster's throughput on a synthetic town (issue 19's benchmark:
// rays per second and seconds per million surface points of the sky-view
// factor at N directions), at 1 thread and at every core. Not a test.
// Usage: raycast_bench BUILDINGS DIRECTIONS POINTS OUT.json
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include "atlas/raycast.h"
#include "atlas/sky_view.h"
#include "ingest/synth/town.h"

using namespace cityatlas;

int main(int argc, char** argv) {
    if (argc != 5) {
        std::fprintf(stderr, "usage: raycast_bench BUILDINGS DIRECTIONS POINTS OUT.json\n");
        return 2;
    }
    const auto buildings = static_cast<uint32_t>(std::stoul(argv[1]));
    const int directions = std::stoi(argv[2]);
    const auto wanted = static_cast<size_t>(std::stoul(argv[3]));
    using Clock = std::chrono::steady_clock;
    const auto seconds = [](Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); };

    synth::TownSettings s;
    s.buildings = buildings;
    s.texture_size_px = 16;
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
    std::ofstream out(argv[4]);
    out << "{\"benchmark\":\"raycast\",\"buildings\":" << buildings << ",\"triangles\":" << caster->triangles()
        << ",\"directions\":" << directions << ",\"points\":" << points.size() << ",\"build_seconds\":" << build_s
        << ",\"runs\":[" << runs << "]}\n";
    return out ? 0 : 1;
}
