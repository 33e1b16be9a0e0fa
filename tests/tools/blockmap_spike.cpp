// SPDX-License-Identifier: GPL-3.0-or-later
// Issue 20's spike: a root BlockMap (papers/002, SEED-FEATURES.md §1) of a
// synthetic town, against the root's geometry and atlases in a built folder:
// bytes, build seconds and frame time. Not a test. The planes and colours
// are atlas/blockmap.h's (cells with top, base, building and first column;
// distance plane; one column per exposed side, shelf-packed into a
// 1024-wide wall image; column table; feature ids; roof and wall colours
// from the town's textures); their bytes are those of SEED-FEATURES §1.2's
// layout (zstd 19, BC1 colour), without writing a file. Frames are drawn by
// render/gl/blockmap_pass.h on the current EGL device.
//
// Usage: blockmap_spike BUILDINGS TEXTURE_PX TOWN_DIR TILE_FOLDER OUT_DIR [WxH] [FRAMES]
//        blockmap_spike --citygml FILE TILE_FOLDER OUT_DIR [WxH] [FRAMES]   (real data; FILE built into TILE_FOLDER)
//   The town is synth --buildings BUILDINGS --texture-size TEXTURE_PX --lod 2
//   --seed 1 in TOWN_DIR (benchmarks/build_scale.sh's), TILE_FOLDER its build. Writes
//   OUT_DIR/spike.json, OUT_DIR/cameras.json (the same cameras as a camera
//   path for `cityatlas render`) and OUT_DIR/blockmap-<camera>.png.
#include <tbb/parallel_for.h>

#include <zstd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <epoxy/gl.h>
#include <nlohmann/json.hpp>
#include <OpenImageIO/imageio.h>

#include "atlas/blockmap.h"
#include "atlas/raycast.h"
#include "ingest/citygml/citygml_reader.h"
#include "ingest/synth/town.h"
#include "render/gl/blockmap_pass.h"
#include "tiles/blockmap_writer.h"
#include "render/gl/gl_context.h"
#include "render/gl/gl_renderer.h"

using namespace cityatlas;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

size_t zstdBytes(const void* data, size_t n) {
    std::vector<char> out(ZSTD_compressBound(n));
    const size_t r = ZSTD_compress(out.data(), out.size(), data, n, 19);
    return ZSTD_isError(r) ? n : r;
}

// The root BlockMap of the whole scene (the root holds every building) at cell side s, coloured from the textures.
// `coloured`: also the colour planes (else their bytes are still counted: BC1 is fixed rate).
json buildRootBlockMap(const Scene& scene, double s, atlas::BlockMapSample sample, bool coloured, format::BlockMap* out) {
    const auto t0 = Clock::now();
    atlas::BlockMapParams params;
    params.cell_m = s;
    params.sample = sample;
    const atlas::SurfaceTables tables{scene.textures, scene.materials};
    atlas::BlockMapColourStats stats;
    if (Status st = atlas::buildBlockMap(scene.triangles, params, out, coloured ? &tables : nullptr, &stats); !st.ok())
        throw std::runtime_error(st.error);
    const double planes_s = secondsSince(t0);
    const auto t1 = Clock::now();
    const atlas::BlockMapError e = atlas::measureBlockMapError(scene.triangles, *out);
    return {{"planes_s", planes_s}, {"colour_rays", stats.rays}, {"colour_hits", stats.hits},
            {"wall_texels_without_hit", stats.texels_without_hit}, {"unreadable_samples", stats.unreadable_samples},
            {"error_s", secondsSince(t1)}, {"hausdorff_m", e.hausdorff_m}, {"triangles_to_prisms_m", e.triangles_to_prisms_m},
            {"prisms_to_triangles_m", e.prisms_to_triangles_m}};
}

// The column table as the GPU gets it (RGBA16UI: x, y, rows, base).
std::vector<uint16_t> columnTable(const format::BlockMap& bm) {
    std::vector<uint16_t> coltab;
    for (const format::BlockMapColumn& c : bm.columns) coltab.insert(coltab.end(), {c.x, c.y, c.rows, c.base});
    return coltab;
}

// Bytes of §1.2's layout: cells RGBA16UI while feature and column indices fit in 16 bits
// (else RGBA32UI), distance R8UI, the column table, ids, colour as BC1; zstd 19 for the non-colour planes.
json blockMapBytes(const format::BlockMap& bm, double* encode_s) {
    auto t0 = Clock::now();
    const bool narrow = bm.features.size() < 0xFFFF && bm.columns.size() < 0xFFFF;
    std::vector<uint32_t> cells32;
    std::vector<uint16_t> cells16;
    for (const format::BlockMapCell& c : bm.cells) {
        cells32.insert(cells32.end(), {c.top, c.base, c.feature, c.first_column});
        cells16.insert(cells16.end(), {c.top, c.base, static_cast<uint16_t>(c.feature), static_cast<uint16_t>(c.first_column)});
    }
    const std::vector<uint16_t> coltab = columnTable(bm);
    json b;
    const size_t cells_raw = narrow ? cells16.size() * 2 : cells32.size() * 4;
    b["cells_zstd"] = narrow ? zstdBytes(cells16.data(), cells_raw) : zstdBytes(cells32.data(), cells_raw);
    b["dist_zstd"] = zstdBytes(bm.dist.data(), bm.dist.size());
    b["coltab_zstd"] = zstdBytes(coltab.data(), coltab.size() * 2);
    b["fids_zstd"] = zstdBytes(bm.features.data(), bm.features.size() * 4);
    const auto bc1 = [](int w, int h) { return static_cast<size_t>((w + 3) / 4) * static_cast<size_t>((h + 3) / 4) * 8; };
    b["roof_bc1"] = bc1(bm.nx, bm.ny);
    b["walls_bc1"] = bc1(bm.wall_width, bm.wall_height);
    size_t total = 0;
    for (const auto& [k, v] : b.items()) total += v.get<size_t>();
    b["total"] = total;
    b["gpu"] = cells_raw + bm.dist.size() + coltab.size() * 2 + bm.features.size() * 4 + b["roof_bc1"].get<size_t>() +
               b["walls_bc1"].get<size_t>();
    b["cells_16_bit"] = narrow;
    b["file"] = tiles::blockMapFileBytes(bm, tiles::BcQuality::Fast).size();  // the file as the tiles stage writes it
    *encode_s = secondsSince(t0);
    return b;
}

// ---- Cameras and frames.
struct NamedCamera {
    std::string name;
    render::Camera camera;
    Vec3d look_at;
};

render::Camera lookingAt(const Vec3d& position, const Vec3d& target, int width, int height) {
    render::Camera c;
    c.position = position;
    c.direction = (1.0 / length(target - position)) * (target - position);
    c.width_px = width, c.height_px = height;
    c.vertical_fov_deg = 60;
    const double d = length(target - position);
    c.near_m = std::max(1.0, 0.01 * d), c.far_m = 4 * d + 1e5;  // the whole town, also seen from close by
    return c;
}

// Largest |ndc x| or |ndc y| of the box's corners (the client's projection).
double screenExtent(const render::Camera& cam, const Box3d& b) {
    const auto p = render::projection(cam), v = render::viewRotation(cam);
    double m = 0;
    for (int i = 0; i < 8; ++i) {
        const Vec3d q = Vec3d{i & 1 ? b.max.x : b.min.x, i & 2 ? b.max.y : b.min.y, i & 4 ? b.max.z : b.min.z} - cam.position;
        double eye[3];
        for (int r = 0; r < 3; ++r) eye[r] = v[0 * 4 + r] * q.x + v[1 * 4 + r] * q.y + v[2 * 4 + r] * q.z;
        const double w = -eye[2];
        m = std::max({m, std::abs(p[0] * eye[0] / w), std::abs(p[5] * eye[1] / w)});
    }
    return m;
}

// From azimuth 30 degrees, elevation 40 degrees, looking at the box centre:
// `switch` at box distance `switch_m`; `full` where the box just fills the
// frame (along one axis); `close` at a third of that, the frame all box;
// `away` at `switch` looking the other way (a frame's cost without the town).
std::vector<NamedCamera> cameras(const Box3d& b, double switch_m, int width, int height) {
    const Vec3d centre = 0.5 * (b.min + b.max);
    const double az = 30 * M_PI / 180, el = 40 * M_PI / 180;
    const Vec3d dir{std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
    auto at = [&](const char* name, double r) { return NamedCamera{name, lookingAt(centre + r * dir, centre, width, height), centre}; };
    auto bisect = [&](auto&& too_close) {
        double lo = 1, hi = 1e8;
        for (int i = 0; i < 200; ++i) {
            const double mid = std::sqrt(lo * hi);
            (too_close(mid) ? lo : hi) = mid;
        }
        return hi;
    };
    const NamedCamera sw = at("switch", bisect([&](double r) { return render::distanceToBox(centre + r * dir, b) < switch_m; }));
    const double full_r = bisect([&](double r) { return screenExtent(at("", r).camera, b) > 1.0; });
    const Vec3d away_target = sw.camera.position + (sw.camera.position - centre);
    return {sw, at("full", full_r), at("close", 0.35 * full_r),
            NamedCamera{"away", lookingAt(sw.camera.position, away_target, width, height), away_target}};
}

json renderBlockMap(const format::BlockMap& bm, const std::vector<NamedCamera>& cams, int width, int height, int frames,
                    const std::string& out_dir) {
    Status st;
    auto context = render::HeadlessContext::create(&st);
    if (!context) throw std::runtime_error(st.error);
    // No id buffer: as `cityatlas render` draws its frames.
    auto target = render::OffscreenTarget::create(width, height, &st);
    if (!target) throw std::runtime_error(st.error);
    auto pass = render::BlockMapPass::create(&st);
    if (!pass) throw std::runtime_error(st.error);
    render::GpuBlockMap gpu = pass->upload(bm, bm.roof, bm.walls, &st);
    if (!gpu.valid()) throw std::runtime_error(st.error);
    json out = json::object();
    out["renderer"] = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    for (const NamedCamera& nc : cams) {
        target->bind();
        std::vector<double> ms;
        for (int f = 0; f < frames + 2; ++f) {
            const auto t0 = Clock::now();
            glClearColor(196 / 255.0f, 218 / 255.0f, 243 / 255.0f, 1);  // the client's sky, as bytes (no sRGB encoding at the clear)
            glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
            pass->draw(gpu, nc.camera);
            glFinish();
            if (f >= 2) ms.push_back(secondsSince(t0) * 1000);
        }
        std::sort(ms.begin(), ms.end());
        std::vector<uint8_t> rgba;
        target->readPixels(&rgba);
        size_t covered = 0;  // pixels not of the clear colour
        for (size_t i = 0; i < rgba.size(); i += 4)
            covered += rgba[i] != rgba[0] || rgba[i + 1] != rgba[1] || rgba[i + 2] != rgba[2];
        const std::string png = out_dir + "/blockmap-" + nc.name + ".png";
        auto img = OIIO::ImageOutput::create(png);
        if (img && img->open(png, OIIO::ImageSpec(width, height, 4, OIIO::TypeDesc::UINT8))) {
            img->write_image(OIIO::TypeDesc::UINT8, rgba.data());
            img->close();
        }
        const Vec3d& p = nc.camera.position;
        out[nc.name] = {{"frame_ms_median", ms[ms.size() / 2]}, {"frame_ms_min", ms.front()}, {"frame_ms_max", ms.back()},
                        {"frames", ms.size()}, {"pixels_covered", covered},
                        {"camera", {{"position", {p.x, p.y, p.z}}, {"look_at", {nc.look_at.x, nc.look_at.y, nc.look_at.z}}}}};
    }
    pass->release(&gpu);
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    // Real data: --citygml FILE in place of the three town arguments.
    const bool real = argc > 1 && std::string(argv[1]) == "--citygml";
    if (argc < 6) {
        std::fprintf(stderr,
                     "usage: blockmap_spike BUILDINGS TEXTURE_PX TOWN_DIR TILE_FOLDER OUT_DIR [WxH] [FRAMES]\n"
                     "       blockmap_spike --citygml FILE TILE_FOLDER OUT_DIR [WxH] [FRAMES]\n");
        return 2;
    }
    try {
        const int args = real ? 2 : 3;  // the town's arguments after the program name
        synth::TownSettings settings;
        if (!real) {
            settings.buildings = static_cast<uint32_t>(std::stoul(argv[1]));
            settings.texture_size_px = std::stoi(argv[2]);
            settings.seed = 1;
        }
        const std::string town = argv[args], folder = argv[args + 1], out_dir = argv[args + 2];
        int width = 1280, height = 720;
        if (argc > args + 3) std::sscanf(argv[args + 3], "%dx%d", &width, &height);
        const int frames = argc > args + 4 ? std::stoi(argv[args + 4]) : 10;

        const json tileset = json::parse(std::ifstream(folder + "/tileset.json"));
        const json& root = tileset["root"];
        const json& extras = root["extras"]["cityatlas"];
        const double switch_m = extras["min_distance_m"];
        // An untextured root has a texel from its geometry alone (London: 9.5 mm): BLOCKMAP_MIN_CELL_M
        // sets the smallest cell the spike uses (reported as cell_m beside the root's texel).
        const char* min_cell = std::getenv("BLOCKMAP_MIN_CELL_M");
        const double texel = std::max(extras["world_texel_m"].get<double>(), min_cell ? std::stod(min_cell) : 0.0);
        json geometry_bytes = json::object();
        size_t root_bytes = 0;
        for (const auto& [layer, l] : extras["layers"].items()) {
            const size_t g = l["geometry"]["bytes"], a = l.contains("atlas") && l["atlas"].is_object() ? l["atlas"]["bytes"].get<size_t>() : 0;
            geometry_bytes[layer] = {{"geometry", g}, {"atlas", a}, {"triangles", l["triangles"]},
                                     {"triangles_source", l["triangles_source"]}, {"geometric_error_m", l["geometric_error_m"]}};
            root_bytes += g + a;
        }
        const std::vector<uint32_t> dropped = extras["features"]["dropped"];

        auto t0 = Clock::now();
        Scene scene;
        if (real) {
            // Read as `build` reads it (default options): the same local frame as the folder.
            SceneCollector collector;
            IngestState state;
            state.sink = &collector;
            if (Status st = readCityGml(town, state); !st.ok()) throw std::runtime_error(st.error);
            scene = std::move(collector.scene);
        } else {
            scene = synth::townToScene(synth::generateTown(settings), town);
        }
        const double scene_s = secondsSince(t0);
        // Plan-view built area (the up-facing triangles projected): every
        // building, and those the root's geometry keeps.
        std::vector<double> roof_area(scene.features.size(), 0);
        for (const Triangle& t : scene.triangles) {
            const Vec3d n = cross(t.position_local[1] - t.position_local[0], t.position_local[2] - t.position_local[0]);
            if (n.z > 0) roof_area[t.feature] += 0.5 * n.z;
        }
        double built_m2 = 0, dropped_m2 = 0;
        for (double a : roof_area) built_m2 += a;
        for (uint32_t f : dropped) dropped_m2 += roof_area[f];
        // A BlockMap of the whole town, described: sizes, buildings present, area, bytes, build.
        auto describe = [&](atlas::BlockMapSample sample, bool coloured, format::BlockMap* bm) {
            auto t = Clock::now();
            json timing = buildRootBlockMap(scene, texel, sample, coloured, bm);
            double encode_s = 0;
            json bytes = blockMapBytes(*bm, &encode_s);
            timing["encode_s"] = encode_s;
            timing["total_s"] = secondsSince(t);
            std::set<uint32_t> present(bm->features.begin(), bm->features.end());
            size_t dropped_present = 0, occupied = 0;
            for (uint32_t f : dropped) dropped_present += present.count(f);
            for (uint8_t v : bm->dist) occupied += v == 0;
            const double s = bm->cell_m;
            return json{{"sample", sample == atlas::BlockMapSample::Max ? "max" : "centre"}, {"grid", {bm->nx, bm->ny}},
                        {"cell_m", s}, {"z_range", {bm->origin.z, bm->z_hi}}, {"occupied_cells", occupied},
                        {"columns", bm->columns.size()}, {"wall_px", {bm->wall_width, bm->wall_height}},
                        {"features", bm->features.size()}, {"dropped_by_geometry_present", dropped_present},
                        {"plan_area_m2", static_cast<double>(occupied) * s * s}, {"bytes", bytes}, {"build", timing},
                        {"voxel_error_bound_m", 0.5 * std::sqrt(2 * s * s + std::pow((bm->z_hi - bm->origin.z) / 65535.0, 2))}};
        };
        format::BlockMap bm, bm_max;
        const json centre = describe(atlas::BlockMapSample::Centre, true, &bm);
        const json max = describe(atlas::BlockMapSample::Max, false, &bm_max);
        Box3d box;
        const double s = bm.cell_m;
        box.min = bm.origin;
        box.max = {bm.origin.x + bm.nx * s, bm.origin.y + bm.ny * s, bm.z_hi};
        const auto cams = cameras(box, switch_m, width, height);

        json report;
        report["town"] = {{"source", real ? town : "synth"}, {"buildings", real ? scene.features.size() : settings.buildings},
                          {"texture_px", settings.texture_size_px},
                          {"features", scene.features.size()}, {"triangles", scene.triangles.size()}, {"scene_s", scene_s}};
        report["root"] = {{"folder", folder}, {"world_texel_m", extras["world_texel_m"]}, {"min_distance_m", switch_m}, {"bytes", root_bytes},
                          {"layers", geometry_bytes}, {"features_drawn", extras["features"]["count"]},
                          {"features_dropped", dropped.size()}};
        report["blockmap"] = centre;
        report["blockmap_max"] = max;  // planes only (its colour bytes counted, not built)
        report["plan_area_m2"] = {{"buildings", built_m2}, {"root_geometry", built_m2 - dropped_m2},
                                  {"blockmap_cells", centre["plan_area_m2"]}, {"blockmap_max_cells", max["plan_area_m2"]}};
        report["render"] = renderBlockMap(bm, cams, width, height, frames, out_dir);
        report["render"]["size"] = {width, height};
        std::ofstream(out_dir + "/spike.json") << report.dump(1) << "\n";
        json path = {{"interpolation", "linear"}, {"frame_rate", 20}, {"keyframes", json::array()}};
        double time = 0;
        for (const NamedCamera& c : cams)
            for (int rep = 0; rep < 40; ++rep, time += 0.05)
                path["keyframes"].push_back({{"time_s", time},
                                             {"position", {c.camera.position.x, c.camera.position.y, c.camera.position.z}},
                                             {"look_at", {c.look_at.x, c.look_at.y, c.look_at.z}}, {"label", c.name},
                                             {"cut", rep == 0 && time > 0}});
        std::ofstream(out_dir + "/cameras.json") << path.dump(1) << "\n";
        std::printf("%s\n", report.dump(1).c_str());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "blockmap_spike: %s\n", e.what());
        return 1;
    }
    return 0;
}
