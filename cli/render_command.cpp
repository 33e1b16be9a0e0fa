// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas render`: plays a camera path over a tile folder or URL headless
// (EGL, Mesa llvmpipe without a GPU), writes PNG frames and a per-frame JSON
// report (schemas/render_report.schema.json).
#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>
#include <stb_image_write.h>

#include "cityatlas_version.h"
#include "cli/commands.h"
#include "cli/outcome.h"
#include "cli/progress.h"
#include "render/client/streaming_client.h"
#include "render/core/camera_path.h"
#include "render/gl/gl_context.h"
#include "render/gl/gl_renderer.h"

namespace cityatlas::cli {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using render::CameraPath;
using Clock = std::chrono::steady_clock;

struct RenderCliOptions {
    std::string source;
    std::string path_file;
    std::string size = "1280x720";
    std::string budget = "512M";
    std::string ram_budget;  // empty: twice the budget
    double speed_limit = 0;
    double tau_speed = 0;
    int preload_levels = -1;
    double lookahead_s = 0;
    double fade_s = -1;  // < 0: 0.25 s in real time, none with --wait
    std::string textures_by_view = "on";
    std::string out_dir;
    std::string report;
    std::string mode = "atlas";
    std::string priority = "distance";
    std::string blockmaps = "on";
    bool wait = false;
    double wait_timeout_s = 300;
    int every = 1;
    int frames = 0;
    double fps = 0;
    double tau = 1;
    int max_requests = 16;
    double upload_ms = 8;
    float anisotropy = 4;
    bool cpu_decode = false;
    int threads = 2;
    std::string picks_file;  // JSON [[x, y], ...]: picked after the last frame
    bool ids = false;        // write the id buffer next to each frame written
    bool edges = false;      // edge enhancement (render/gl/edge_pass.h)
    float edge_strength = 0.5F;
    bool quiet = false;
    std::string computed;                 // a computed texture's name; empty: none
    std::string computed_mode = "ramp";
    std::string computed_range = "0.3,1";
};

// "512M", "2G", "1500000", "64k": bytes (powers of 1024).
bool parseBytes(const std::string& text, uint64_t* out) {
    static const std::regex re(R"(^\s*([0-9]+(?:\.[0-9]+)?)\s*([kKmMgGtT]?)i?[bB]?\s*$)");
    std::smatch m;
    if (!std::regex_match(text, m, re)) return false;
    double v = std::stod(m[1]);
    switch (m[2].str().empty() ? ' ' : std::tolower(m[2].str()[0])) {
        case 't': v *= 1024.0;
        [[fallthrough]];
        case 'g': v *= 1024.0;
        [[fallthrough]];
        case 'm': v *= 1024.0;
        [[fallthrough]];
        case 'k': v *= 1024.0;
        [[fallthrough]];
        default: break;
    }
    if (!(v >= 1 && v < 1.8e19)) return false;
    *out = static_cast<uint64_t>(v);
    return true;
}

// The id buffer as raw little-endian uint32 (the machines this builds on are
// little-endian; the static_assert says so), written whole or not at all.
Status writeIds(const fs::path& path, const std::vector<uint32_t>& ids) {
    static_assert(std::endian::native == std::endian::little, "ids_*.bin is written little-endian");
    const fs::path tmp = fs::path(path).concat(".partial");
    {
        std::ofstream f(tmp, std::ios::binary);
        f.write(reinterpret_cast<const char*>(ids.data()), static_cast<std::streamsize>(ids.size() * sizeof(uint32_t)));
        if (!f) return Status::Io(fmt::format("{}: cannot write", path.string()));
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) return Status::Io(fmt::format("{}: cannot write: {}", path.string(), ec.message()));
    return Status::Ok();
}

bool parseSize(const std::string& text, int* w, int* h) {
    static const std::regex re(R"(^([0-9]{1,5})x([0-9]{1,5})$)");
    std::smatch m;
    if (!std::regex_match(text, m, re)) return false;
    *w = std::stoi(m[1]);
    *h = std::stoi(m[2]);
    return *w >= 16 && *h >= 16 && *w <= 16384 && *h <= 16384;
}

// stb_image_write (Debian's libstb): the client links no image library's
// writer side beyond it.
bool writePng(const fs::path& path, int w, int h, const std::vector<uint8_t>& rgba, std::string* why) {
    // RGB only: the alpha of the frame buffer is not part of the picture.
    std::vector<uint8_t> rgb(static_cast<size_t>(w) * h * 3);
    for (size_t i = 0, n = static_cast<size_t>(w) * h; i < n; ++i)
        for (int c = 0; c < 3; ++c) rgb[i * 3 + static_cast<size_t>(c)] = rgba[i * 4 + static_cast<size_t>(c)];
    const fs::path tmp = fs::path(path).concat(".partial");
    if (stbi_write_png(tmp.string().c_str(), w, h, 3, rgb.data(), w * 3) == 0) {
        *why = "the PNG writer failed (disk full or not writable?)";
        return false;
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) {
        *why = ec.message();
        return false;
    }
    return true;
}

json frameJson(size_t i, const render::CameraSample& s, double wall_s, double waited_ms, bool wait_complete,
               const render::FrameRecord& r, const std::string& image, const render::PickHit& centre) {
    return {{"centre_pick", centre.hit ? json{{"feature", centre.feature}, {"distance_m", centre.distance_m}} : json(nullptr)},
            {"frame", i},
            {"time_s", s.time_s},
            {"label", s.label},
            {"wall_s", wall_s},
            {"frame_ms", r.frame_ms},
            {"waited_ms", waited_ms},
            {"ideal_set_complete", wait_complete},
            {"upload_ms", r.upload_ms},
            {"uploads", r.uploads},
            {"nodes_drawn",
             {{"atlas", r.nodes_atlas}, {"originals", r.nodes_originals}, {"blockmap", r.nodes_blockmap}, {"coarse", r.nodes_coarse}}},
            {"draw_calls", r.draw_calls},
            {"texture_binds", r.texture_binds},
            {"triangles", r.triangles},
            {"root_missing", r.root_missing},
            {"resident_bytes", r.resident_bytes},
            {"requested_bytes", r.requested_bytes},
            {"budget_bytes", r.budget_bytes},
            {"pinned_bytes", r.pinned_bytes},
            {"ideal_bytes", r.ideal_bytes},
            {"needed_bytes", r.needed_bytes},
            {"ram_hits", r.ram_hits},
            {"ram_bytes", r.ram_bytes},
            {"ram_budget_bytes", r.ram_budget_bytes},
            {"speed_mps", r.speed_mps},
            {"speed_limited", r.speed_limited},
            {"coarse_level_min", r.coarse_level_min},
            {"lens_occluders", r.lens_occluders},
            {"lens_occluder_ids", r.lens_occluder_ids},
            {"fading", r.fading},
            {"wasted_bytes", r.wasted_bytes},
            {"requests", {{"geometry", r.requests[0]}, {"atlas", r.requests[1]}, {"textures", r.requests[2]},
                          {"computed", r.requests[3]}, {"blockmap", r.requests[4]}}},
            {"computed_missing_draws", r.computed_missing_draws},
            {"gpu_bytes", r.gpu_bytes},
            {"bytes_loaded", r.bytes_loaded},
            {"requests_in_flight", r.requests_in_flight},
            {"refinement", {{"ideal_blocks", r.ideal_blocks},
                            {"ideal_blocks_by_kind", {{"geometry", r.ideal_blocks_by_kind[0]},
                                                      {"atlas", r.ideal_blocks_by_kind[1]},
                                                      {"textures", r.ideal_blocks_by_kind[2]},
                                                      {"computed", r.ideal_blocks_by_kind[3]},
                                                      {"blockmap", r.ideal_blocks_by_kind[4]}}},
                            {"ideal_missing", r.ideal_missing},
                            {"needed_missing", r.needed_missing},
                            {"ideal_cut_by_budget", r.ideal_cut}}},
            {"errors", r.errors},
            {"failed_blocks", r.failed_blocks},
            {"camera", {{"position", {s.position.x, s.position.y, s.position.z}},
                        {"direction", {s.direction.x, s.direction.y, s.direction.z}},
                        {"fov_deg", s.fov_deg}}},
            {"image", image.empty() ? json(nullptr) : json(image)}};
}

json summaryJson(const json& frames, const std::vector<size_t>& cut_frames, const render::StreamingClient& client,
                 double seconds) {
    double sum_ms = 0, max_ms = 0;
    std::vector<double> frame_ms;  // for the median: first draws with new textures cost far more on some drivers
    uint64_t nodes_max = 0, binds_max = 0, resident_max = 0, bytes = 0;
    double nodes_sum = 0, binds_sum = 0;
    size_t over_budget = 0, root_missing = 0;
    for (const json& f : frames) {
        const double ms = f["frame_ms"];
        sum_ms += ms;
        frame_ms.push_back(ms);
        max_ms = std::max(max_ms, ms);
        const uint64_t nodes = f["nodes_drawn"]["atlas"].get<uint64_t>() + f["nodes_drawn"]["originals"].get<uint64_t>();
        nodes_sum += static_cast<double>(nodes);
        nodes_max = std::max(nodes_max, nodes);
        binds_sum += f["texture_binds"].get<double>();
        binds_max = std::max(binds_max, f["texture_binds"].get<uint64_t>());
        resident_max = std::max(resident_max, f["resident_bytes"].get<uint64_t>());
        bytes += f["bytes_loaded"].get<uint64_t>();
        over_budget += f["resident_bytes"].get<uint64_t>() + f["pinned_bytes"].get<uint64_t>() > f["budget_bytes"].get<uint64_t>()
                           ? 1
                           : 0;
        root_missing += f["root_missing"].get<bool>() ? 1 : 0;
    }
    const double n = frames.empty() ? 1.0 : static_cast<double>(frames.size());
    double median_ms = 0;
    if (!frame_ms.empty()) {
        const size_t mid = frame_ms.size() / 2;
        std::nth_element(frame_ms.begin(), frame_ms.begin() + static_cast<std::ptrdiff_t>(mid), frame_ms.end());
        median_ms = frame_ms[mid];
        if (frame_ms.size() % 2 == 0)
            median_ms = 0.5 * (median_ms + *std::max_element(frame_ms.begin(), frame_ms.begin() + static_cast<std::ptrdiff_t>(mid)));
    }
    // Teleports: wall time from the cut's frame until the first frame whose
    // needed blocks (the view at full resolution) / whole ideal set (with the
    // prefetch that fills the budget) are resident.
    json teleports = json::array();
    for (const size_t c : cut_frames) {
        if (c >= frames.size()) continue;
        json t = {{"frame", c}, {"label", frames[c]["label"]}, {"seconds_to_ideal_set", nullptr},
                  {"seconds_to_needed_set", nullptr}};
        for (const char* what : {"ideal", "needed"}) {
            for (size_t k = c; k < frames.size(); ++k) {
                if (frames[k]["refinement"][fmt::format("{}_missing", what)].get<uint64_t>() != 0) continue;
                t[fmt::format("seconds_to_{}_set", what)] = frames[k]["wall_s"].get<double>() -
                                                            frames[c]["wall_s"].get<double>() +
                                                            frames[k]["frame_ms"].get<double>() / 1000.0;
                t[fmt::format("frames_to_{}_set", what)] = k - c;
                break;
            }
        }
        teleports.push_back(t);
    }
    const render::LoaderStats ls = client.loaderStats();
    json errors = json::array();
    for (size_t i = 0; i < client.errors().size() && i < 50; ++i) errors.push_back(client.errors()[i]);
    return {{"frames", frames.size()},
            {"seconds", seconds},
            {"frame_ms_mean", sum_ms / n},
            {"frame_ms_max", max_ms},
            {"frame_ms_median", median_ms},
            {"nodes_drawn_mean", nodes_sum / n},
            {"nodes_drawn_max", nodes_max},
            {"texture_binds_mean", binds_sum / n},
            {"texture_binds_max", binds_max},
            {"bytes_loaded", bytes},
            {"resident_bytes_max", resident_max},
            {"frames_over_budget", over_budget},
            {"frames_root_missing", root_missing},
            {"requests", ls.requests},
            {"retries", ls.retries},
            {"errors", client.errors().size()},
            {"error_messages", errors},
            {"teleports", teleports}};
}

int runRender(const RenderCliOptions& opt) {
    auto fail = [](const Status& s) { return cli::fail("render", s); };
    auto usage = [](const std::string& message) { return cli::fail("render", Status::Usage(message)); };
    int width = 0, height = 0;
    if (!parseSize(opt.size, &width, &height)) return usage(fmt::format("--size {}: expected WxH, 16..16384 each", opt.size));
    uint64_t budget = 0;
    if (!parseBytes(opt.budget, &budget)) return usage(fmt::format("--budget {}: expected bytes, e.g. 512M or 2G", opt.budget));

    render::ClientOptions co;
    co.budget_bytes = budget;
    uint64_t ram_budget = 2 * budget;
    if (!opt.ram_budget.empty() && opt.ram_budget != "0" && !parseBytes(opt.ram_budget, &ram_budget))
        return usage(fmt::format("--ram-budget {}: expected bytes, e.g. 1G, or 0 (off)", opt.ram_budget));
    if (opt.ram_budget == "0") ram_budget = 0;
    co.loader.ram_budget_bytes = ram_budget;
    co.speed_limit_mps = opt.speed_limit;
    co.tau_speed_mps = opt.tau_speed;
    co.preload_levels = opt.preload_levels;
    co.lookahead_s = opt.lookahead_s;
    co.textures_by_view = opt.textures_by_view == "on";
    co.fade_s = opt.fade_s >= 0 ? opt.fade_s : opt.wait ? 0.0 : 0.25;
    co.max_requests = static_cast<uint32_t>(opt.max_requests);
    co.upload_ms_per_frame = opt.upload_ms;
    co.selection.tau = opt.tau;
    co.selection.priority = opt.priority == "view" ? render::PriorityMode::ViewWeighted : render::PriorityMode::Distance;
    co.selection.blockmaps = opt.blockmaps == "on";
    co.mode = opt.mode == "original" ? render::TextureMode::Original
              : opt.mode == "dummy"  ? render::TextureMode::Dummy
                                     : render::TextureMode::AtlasTree;
    co.max_anisotropy = opt.anisotropy;
    co.cpu_decode = opt.cpu_decode;
    render::ComputedStyle computed_style;
    if (!opt.computed.empty()) {
        if (opt.computed_mode == "ramp") computed_style.mode = render::ComputedMode::Ramp;
        else if (opt.computed_mode == "modulate") computed_style.mode = render::ComputedMode::Modulate;
        else if (opt.computed_mode == "emphasis") computed_style.mode = render::ComputedMode::Emphasis;
        else if (opt.computed_mode == "photo") computed_style.mode = render::ComputedMode::Photo;
        else return usage(fmt::format("--computed-mode {}: expected ramp, modulate, emphasis or photo", opt.computed_mode));
        char tail = 0;
        if (std::sscanf(opt.computed_range.c_str(), "%f,%f%c", &computed_style.b_min, &computed_style.b_max, &tail) != 2 ||
            !(computed_style.b_min >= 0 && computed_style.b_max >= computed_style.b_min && computed_style.b_max <= 16))
            return usage(fmt::format("--computed-range {}: expected BMIN,BMAX with 0 <= BMIN <= BMAX", opt.computed_range));
    }
    co.loader.decode_threads = opt.threads;
    render::EdgeStyle edges;
    edges.enabled = opt.edges;
    edges.strength = opt.edge_strength;

    // The GL context first: it must outlive the client and the target, which free GL objects.
    Status st;
    auto context = render::HeadlessContext::create(&st);
    if (!context) return fail(st);
    auto client = render::StreamingClient::open(opt.source, co, &st);
    if (!client) return fail(st);
    if (!opt.computed.empty()) {
        const std::vector<std::string>& names = client->index().computed;
        const auto it = std::find(names.begin(), names.end(), opt.computed);
        if (it == names.end())
            return usage(fmt::format("--computed {}: {} has {}", opt.computed, opt.source,
                                     names.empty() ? std::string("no computed textures (build it with --computed)")
                                                   : fmt::format("only {}", fmt::join(names, ", "))));
        client->setComputed(static_cast<int>(it - names.begin()), computed_style);
    }

    CameraPath path;
    std::string path_name = "default (overview, oblique flight, street level)";
    if (!opt.path_file.empty()) {
        std::ifstream f(opt.path_file);
        if (!f) return fail(Status::Io(fmt::format("{}: cannot read", opt.path_file)));
        std::stringstream ss;
        ss << f.rdbuf();
        if (Status ps = render::parseCameraPath(ss.str(), opt.path_file, &path); !ps.ok()) return fail(ps);
        path_name = opt.path_file;
    } else {
        path = render::defaultPath(client->index().nodes[0].bounds);
    }
    if (opt.fps > 0) path.frame_rate = opt.fps;
    if (path.lens.poi >= 0 && static_cast<uint64_t>(path.lens.poi) >= client->index().feature_count)
        return fail(Status::Usage(fmt::format("{}: lens building {} does not exist (the folder has {} features)", path_name,
                                              path.lens.poi, client->index().feature_count)));
    client->setLens(path.lens);
    size_t frames = path.frameCount();
    if (opt.frames > 0) frames = std::min(frames, static_cast<size_t>(opt.frames));

    const render::GlInfo gl = render::queryGlInfo();
    if (opt.ids && opt.out_dir.empty()) return usage("--ids needs -o/--output (the id buffers are written next to the frames)");
    auto target = render::OffscreenTarget::create(width, height, &st, opt.ids || opt.edges);  // edges read the id buffer
    if (!target) return fail(st);
    if (Status gs = client->initGl(); !gs.ok()) return fail(gs);
    client->setEdges(edges, target.get());
    if (!opt.quiet && client->usesCpuDecode())
        note("render", fmt::format("{} has no sRGB S3TC: textures are decoded on the CPU (4 bytes per texel)", gl.renderer));

    std::error_code ec;
    if (!opt.out_dir.empty()) {
        fs::create_directories(opt.out_dir, ec);
        if (ec) return fail(Status::Io(fmt::format("{}: cannot create: {}", opt.out_dir, ec.message())));
    }
    std::vector<size_t> cut_frames;
    for (const render::CameraKey& k : path.keys) {
        if (!k.cut) continue;
        const double f = std::ceil((k.time_s - path.keys.front().time_s) * path.frame_rate - 1e-9);
        cut_frames.push_back(static_cast<size_t>(std::max(0.0, f)));
    }

    std::vector<std::pair<double, double>> picks;
    if (!opt.picks_file.empty()) {
        std::ifstream f(opt.picks_file);
        const json j = json::parse(f, nullptr, false);
        if (!f || !j.is_array()) return fail(Status::Usage(fmt::format("{}: not a JSON array of [x, y] pixels", opt.picks_file)));
        for (const json& p : j) {
            if (!p.is_array() || p.size() != 2 || !p[0].is_number() || !p[1].is_number())
                return fail(Status::Usage(fmt::format("{}: {} is not an [x, y] pixel", opt.picks_file, p.dump())));
            picks.emplace_back(p[0].get<double>(), p[1].get<double>());
        }
    }
    auto cameraFor = [&](const render::CameraSample& s) {
        render::Camera c;
        c.position = s.position;
        c.direction = s.direction;
        c.vertical_fov_deg = s.fov_deg;
        c.width_px = width;
        c.height_px = height;
        return c;
    };
    // The root comes first: the client never shows a frame without texture.
    const render::Camera first = cameraFor(render::sampleFrame(path, 0));
    if (Status ws = client->waitForRoot(first, opt.wait_timeout_s); !ws.ok()) return fail(ws);

    Progress progress(!opt.quiet);
    json frame_list = json::array();
    std::vector<uint8_t> pixels;
    std::vector<uint32_t> ids;
    const auto start = Clock::now();
    for (size_t i = 0; i < frames; ++i) {
        const render::CameraSample s = render::sampleFrame(path, i);
        const render::Camera cam = cameraFor(s);
        client->setFrameTime(s.time_s);  // cross-fades run on path time
        // The camera's speed over the path time since the previous frame; a cut is a teleport, not motion.
        const bool cut_here = std::find(cut_frames.begin(), cut_frames.end(), i) != cut_frames.end();
        if (i > 0 && !cut_here) {
            const render::CameraSample prev = render::sampleFrame(path, i - 1);
            const double dt = s.time_s - prev.time_s;
            client->setCameraVelocity(dt > 0 ? (1.0 / dt) * (s.position - prev.position) : Vec3d{0, 0, 0});
        } else {
            client->setCameraVelocity({0, 0, 0});
        }
        double waited_ms = 0;
        bool complete = true;
        if (opt.wait) {
            const auto w0 = Clock::now();
            complete = client->waitForIdealSet(cam, opt.wait_timeout_s);
            waited_ms = std::chrono::duration<double, std::milli>(Clock::now() - w0).count();
        } else {
            // Real time: frame i is shown at path time i / fps (never early); until
            // then the client uploads and plans, as a viewer does within its frame interval.
            const auto due = start + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(static_cast<double>(i) / path.frame_rate));
            const double idle_s = std::chrono::duration<double>(due - Clock::now()).count();
            if (idle_s > 0) client->idle(cam, idle_s);
        }
        const double wall_s = std::chrono::duration<double>(Clock::now() - start).count();
        target->bind();
        const render::FrameRecord r = client->frame(cam);
        std::string image;
        if (!opt.out_dir.empty() && i % static_cast<size_t>(opt.every) == 0) {
            image = fmt::format("frame_{:05d}.png", i);
            target->readPixels(&pixels);
            std::string why;
            if (!writePng(fs::path(opt.out_dir) / image, width, height, pixels, &why))
                return fail(Status::Io(fmt::format("{}: cannot write: {}", (fs::path(opt.out_dir) / image).string(), why)));
            if (opt.ids) {
                const fs::path ids_path = fs::path(opt.out_dir) / fmt::format("ids_{:05d}.bin", i);
                target->readIds(&ids);
                if (Status ws = writeIds(ids_path, ids); !ws.ok()) return fail(ws);
            }
        }
        // The building at the image centre, as `view` picks on a click.
        const render::PickHit centre = client->pick(cam, 0.5 * width, 0.5 * height);
        frame_list.push_back(frameJson(i, s, wall_s, waited_ms, complete, r, image, centre));
        progress.update("frames", i + 1, frames);
    }
    // Picks at given pixels of the last frame (the view's ray cast), with each building's gml:id.
    json pick_list = json::array();
    if (!picks.empty() && frames > 0) {
        const render::Camera cam = cameraFor(render::sampleFrame(path, frames - 1));
        for (const auto& [px, py] : picks) {
            const render::PickHit hit = client->pick(cam, px, py);
            json p = {{"x", px}, {"y", py}, {"hit", hit.hit}};
            // What the id buffer holds at that pixel (the last frame's), next to the ray cast's answer.
            if (opt.ids) {
                const uint32_t id = target->idAt(static_cast<int>(std::floor(px)), static_cast<int>(std::floor(py)));
                p["id_buffer"] = id == render::OffscreenTarget::kNoFeature ? json(nullptr) : json(id);
            }
            if (hit.hit) {
                p["feature"] = hit.feature;
                p["distance_m"] = hit.distance_m;
                std::string record;
                if (client->featureRecord(hit.feature, &record).ok()) {
                    const json r = json::parse(record, nullptr, false);
                    if (r.is_object() && r.contains("gml_id")) p["gml_id"] = r["gml_id"];
                }
            }
            pick_list.push_back(p);
        }
    }
    progress.finish();
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();

    const json summary = summaryJson(frame_list, cut_frames, *client, seconds);
    json report = {{"generator", std::string("cityatlas ") + kCityAtlasVersion},
                   {"source", opt.source},
                   {"tileset_version", client->index().tileset_version},
                   {"settings", {{"size", {width, height}},
                                 {"budget_bytes", budget},
                                 {"ram_budget_bytes", co.loader.ram_budget_bytes},
                                 {"speed_limit_mps", co.speed_limit_mps},
                                 {"tau_speed_mps", co.tau_speed_mps},
                                 {"preload_level", client->preloadLevel()},
                                 {"lookahead_s", co.lookahead_s},
                                 {"fade_s", co.fade_s},
                                 {"textures_by_view", co.textures_by_view},
                                 {"mode", render::textureModeName(co.mode)},
                                 {"priority", render::priorityModeName(co.selection.priority)},
                                 {"tau", opt.tau},
                                 {"wait_for_ideal_set", opt.wait},
                                 {"max_requests", opt.max_requests},
                                 {"upload_ms_per_frame", opt.upload_ms},
                                 {"anisotropy", opt.anisotropy},
                                 {"cpu_decode", opt.cpu_decode},
                                 {"path", path_name},
                                 {"frame_rate", path.frame_rate}}},
                   {"gl", {{"vendor", gl.vendor},
                           {"renderer", gl.renderer},
                           {"version", gl.version},
                           {"s3tc", gl.s3tc},
                           {"cpu_decode", client->usesCpuDecode()}}},
                   {"tileset", {{"nodes", client->index().nodes.size()},
                                {"blocks", client->index().blocks.size()},
                                {"bytes", client->index().bytes_total},
                                {"bytes_geometry", client->index().bytes_by_kind[0]},
                                {"bytes_atlases", client->index().bytes_by_kind[1]},
                                {"bytes_textures", client->index().bytes_by_kind[2]},
                                {"bytes_blockmaps", client->index().bytes_by_kind[4]}}},
                   {"summary", summary},
                   {"frames", frame_list}};
    if (!picks.empty()) report["picks"] = pick_list;
    if (!opt.computed.empty())
        report["settings"]["computed"] = {{"name", opt.computed},
                                          {"mode", render::computedModeName(computed_style.mode)},
                                          {"range", {computed_style.b_min, computed_style.b_max}}};
    std::string report_path = opt.report;
    if (report_path.empty() && !opt.out_dir.empty()) report_path = (fs::path(opt.out_dir) / "report.json").string();
    if (!report_path.empty()) {
        std::ofstream f(report_path);
        f << report.dump(1) << "\n";
        if (!f) return fail(Status::Io(fmt::format("{}: cannot write", report_path)));
    }
    if (!opt.quiet) {
        fmt::print("{} frames ({}x{}, {} mode{}) in {:.1f} s: frame {:.1f} ms mean, {:.1f} ms worst; nodes {:.1f} mean, {} "
                   "worst; texture binds {:.1f} mean; {} loaded; {} errors\n",
                   frame_list.size(), width, height, render::textureModeName(co.mode), opt.wait ? ", waiting for the ideal set" : "",
                   seconds, summary["frame_ms_mean"].get<double>(), summary["frame_ms_max"].get<double>(),
                   summary["nodes_drawn_mean"].get<double>(), summary["nodes_drawn_max"].get<uint64_t>(),
                   summary["texture_binds_mean"].get<double>(), humanBytes(summary["bytes_loaded"].get<uint64_t>()),
                   summary["errors"].get<uint64_t>());
        const auto seconds = [](const json& s) { return s.is_null() ? std::string("never") : fmt::format("{:.2f} s", s.get<double>()); };
        for (const json& t : summary["teleports"])
            fmt::print("teleport at frame {} ({}): needed blocks after {}, whole ideal set after {}\n",
                       t["frame"].get<size_t>(), t["label"].get<std::string>(), seconds(t["seconds_to_needed_set"]),
                       seconds(t["seconds_to_ideal_set"]));
        if (!report_path.empty()) fmt::print("report: {}\n", report_path);
    }
    return kExitOk;
}

}  // namespace

RunFn addRenderCommand(CLI::App& app) {
    auto opt = std::make_shared<RenderCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "render",
        "Render a tile folder or URL headless (EGL; Mesa llvmpipe when there is no GPU) along a camera path:\n"
        "PNG frames and a per-frame JSON report (schemas/render_report.schema.json). Without --path it flies a\n"
        "default path from the tileset's bounds: overview, oblique flight, street level.");
    cmd->add_option("source", opt->source, "Tile folder (holding tileset.json) or http(s):// URL of one")->required();
    cmd->add_option("--path", opt->path_file, "Camera path JSON (schemas/camera_path.schema.json); default: derived from the bounds");
    cmd->add_option("--size", opt->size, "Frame size WxH")->default_val("1280x720");
    cmd->add_option("--budget", opt->budget, "Memory budget for resident blocks (tileset.json sizes): bytes or 512M, 2G")
        ->default_val("512M");
    cmd->add_option("--ram-budget", opt->ram_budget,
                    "The RAM level below the budget: block bytes as fetched, kept after the GPU lets them go, least "
                    "recently in an ideal set evicted first; a request finds them there without I/O. Bytes, e.g. 1G; "
                    "0: off; default twice --budget");
    cmd->add_option("--speed-limit", opt->speed_limit,
                    "Speed policy: while the camera moves faster than this (m/s of path time), request only the "
                    "blocks on screen at atlas levels (no original textures, no prefetch); 0: off")
        ->default_val(0)
        ->check(CLI::Range(0.0, 1e9));
    cmd->add_option("--preload-levels", opt->preload_levels,
                    "Keep every node of level <= L resident wherever the camera is (lowered until they fit a quarter "
                    "of the budget), so no frame after a teleport is coarser than level L; -1: off")
        ->default_val(-1)
        ->check(CLI::Range(-1, 64));
    cmd->add_option("--fade-s", opt->fade_s,
                    "Smooth refinement: seconds of path time over which a node's replacement (children, originals, "
                    "or coarser back) fades in over it (screen-door dither); 0: off; default 0.25, and 0 with --wait "
                    "(pictures of the finished ideal set)")
        ->check(CLI::Range(0.0, 60.0));
    cmd->add_option("--textures-by-view", opt->textures_by_view,
                    "on: a leaf drawn with its originals loads only the texture blocks the camera sees (in view and "
                    "closer than the leaf's min distance, known once its geometry is loaded; in a folder built with "
                    "--split-originals on, only the tiles in view); off: every block of the leaf")
        ->default_val("on")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option("--lookahead-s", opt->lookahead_s,
                    "Also plan for the camera moved by its velocity times this many seconds (each block keeps the "
                    "better of its two priorities, one budget); 0: off")
        ->default_val(0)
        ->check(CLI::Range(0.0, 3600.0));
    cmd->add_option("--tau-speed", opt->tau_speed,
                    "Continuous speed policy: tau grows to tau * max(1, speed / K) while moving (coarser atlases "
                    "suffice); K in m/s, 0: off")
        ->default_val(0)
        ->check(CLI::Range(0.0, 1e9));
    cmd->add_option("-o,--output", opt->out_dir, "Folder for the PNG frames (and report.json unless --report)");
    cmd->add_option("--report", opt->report, "Per-frame JSON report (default OUTPUT/report.json)");
    cmd->add_option("--every", opt->every, "Write every n-th frame as PNG")->default_val(1)->check(CLI::Range(1, 1000000));
    cmd->add_option("--frames", opt->frames, "Render at most this many frames (0: the whole path)")->default_val(0)
        ->check(CLI::Range(0, 10000000));
    cmd->add_option("--fps", opt->fps, "Frames per second of path time (default: the path's frame_rate)")
        ->check(CLI::Range(0.01, 1000.0));
    cmd->add_option("--mode", opt->mode, "atlas: the atlas tree (originals close by); original: every leaf with its "
                                         "original textures (reference); dummy: the atlas tree's draws with one texture")
        ->default_val("atlas")
        ->check(CLI::IsMember({"atlas", "original", "dummy"}));
    cmd->add_flag("--wait", opt->wait, "Before each frame, load until the ideal block set is resident (images that do not "
                                       "depend on timing); otherwise frames play in real time while blocks stream");
    cmd->add_option("--wait-timeout", opt->wait_timeout_s, "Seconds to wait for the root / an ideal set")->default_val(300);
    cmd->add_option("--tau", opt->tau, "Pixels per texel accepted (> 1: coarser, fewer loads)")->default_val(1.0)
        ->check(CLI::Range(0.1, 64.0));
    cmd->add_option("--blockmaps", opt->blockmaps,
                    "Draw the folder's BlockMaps (build --blockmaps) where a node's distance allows: on, or off (its geometry and "
                    "atlases only; refused on a folder built with --blockmaps replace, whose upper levels are BlockMaps alone)")
        ->default_val("on")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option("--priority", opt->priority, "Order within a usage category: distance (the papers) or view "
                                                 "(cesium-native's distance x (1 - cos angle to the view direction))")
        ->default_val("distance")
        ->check(CLI::IsMember({"distance", "view"}));
    cmd->add_option("--max-requests", opt->max_requests, "Requests in flight at most")->default_val(16)->check(CLI::Range(1, 1024));
    cmd->add_option("--upload-ms", opt->upload_ms, "GPU upload time per frame, milliseconds (at least one block)")
        ->default_val(8.0)
        ->check(CLI::Range(0.0, 10000.0));
    cmd->add_option("--anisotropy", opt->anisotropy, "Anisotropic filtering (1 = off; llvmpipe's is slow and blurry)")
        ->default_val(4.0F)
        ->check(CLI::Range(1.0F, 16.0F));
    cmd->add_flag("--cpu-decode", opt->cpu_decode,
                  "Decode BC1/BC3 on the CPU and upload RGBA8: for drivers that sample compressed textures slowly "
                  "(Mesa llvmpipe). The budget still counts the files' bytes, so textures take 4-8x the budget "
                  "in memory (the report's gpu_bytes)");
    cmd->add_option("--threads", opt->threads, "Decoding threads")->default_val(2)->check(CLI::Range(1, 256));
    cmd->add_option("--picks", opt->picks_file,
                    "JSON file [[x, y], ...]: after the last frame, pick the building at each pixel (from the top "
                    "left) as `view` does on a click; the report's \"picks\" gives feature, gml_id and distance");
    cmd->add_flag("--ids", opt->ids,
                  "Also write each frame's id buffer as ids_NNNNN.bin next to its PNG: width x height uint32 "
                  "(little-endian, top row first), the building index drawn at each pixel, 0xFFFFFFFF for none; "
                  "with --picks, each pick also gives the id buffer's value at its pixel");
    cmd->add_option("--computed", opt->computed,
                    "Show a computed texture of the folder (build --computed: sky_view, sun_hours, shadow, visibility) on its "
                    "textured surfaces; only its blocks are loaded, under the same budget, and a node shows the photo "
                    "until they arrive");
    cmd->add_option("--computed-mode", opt->computed_mode,
                    "ramp: the value as a blue-to-yellow colour ramp; modulate: the photo times min(1, BMIN + value "
                    "(BMAX - BMIN)) (papers/000 Fig. 20); emphasis: that, with the photo's saturation following the value "
                    "and a touch of yellow where it is high (Fig. 34, for visibility:BUILDING); photo: the photo only (none "
                    "of its blocks load)")
        ->default_val("ramp");
    cmd->add_option("--computed-range", opt->computed_range, "modulate, emphasis: BMIN,BMAX")->default_val("0.3,1");
    cmd->add_flag("--edges", opt->edges,
                  "Edge enhancement (papers/000 §5.2): darken buildings' outlines (the id buffer) and creases and depth "
                  "steps (the depth buffer) so volumes without photos read apart");
    cmd->add_option("--edge-strength", opt->edge_strength, "With --edges: the darkening at an edge, in linear light")
        ->default_val(0.5)
        ->check(CLI::Range(0.0, 1.0));
    cmd->add_flag("-q,--quiet", opt->quiet, "No progress and no summary line");
    return [opt]() { return runRender(*opt); };
}

}  // namespace cityatlas::cli
