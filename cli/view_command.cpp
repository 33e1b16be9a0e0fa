// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas view`: a window onto a tile folder or URL, streaming under a
// memory budget, with fly and orbit navigation and an overlay of statistics
// and controls (Dear ImGui).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <GLFW/glfw3.h>
#include <imgui.h>

#include "cli/commands.h"
#include "cli/outcome.h"
#include "cli/progress.h"
#include "render/client/streaming_client.h"
#include "render/core/camera_path.h"
#include "render/gl/gl_context.h"
#include "render/gl/gl_renderer.h"
#include "render/gl/overlay.h"

namespace cityatlas::cli {
namespace {
using Clock = std::chrono::steady_clock;

struct ViewCliOptions {
    std::string source;
    int width = 1600, height = 900;
    double budget_mb = 512;
    double ram_budget_mb = -1;  // < 0: twice the budget
    double speed_limit = 0, tau_speed = 0;
    double tau = 1;
    std::string mode = "atlas";
    std::string priority = "distance";
    std::string blockmaps = "on";
    bool no_vsync = false;
    int frames = 0;
    std::string computed;               // shown from the start; empty: the photo
    std::string computed_mode = "ramp";
};

// Fly: WASD along the view, Q/E down/up, right mouse drag looks around.
// Orbit: left mouse drag turns around the pivot, scroll moves towards it.
// Speed follows the height above the city's floor: slow in the street, fast above the roofs.
struct Navigation {
    render::Camera camera;
    double yaw = 0, pitch = 0;  ///< radians; yaw 0 looks along +y, pitch < 0 looks down
    Vec3d pivot;
    double floor_z = 0;
    bool orbit = false;
    double last_x = 0, last_y = 0;
    bool dragging_left = false, dragging_right = false;
    double press_x = 0, press_y = 0;

    void setDirection(const Vec3d& d) {
        const Vec3d n = render::normalized(d);
        yaw = std::atan2(n.x, n.y);
        pitch = std::asin(std::clamp(n.z, -1.0, 1.0));
        apply();
    }
    void apply() {
        pitch = std::clamp(pitch, -1.55, 1.55);
        camera.direction = {std::sin(yaw) * std::cos(pitch), std::cos(yaw) * std::cos(pitch), std::sin(pitch)};
    }
    double speed() const { return std::max(3.0, 1.5 * (camera.position.z - floor_z)); }
};

int runView(const ViewCliOptions& opt) {
    auto fail = [](const Status& s) { return cli::fail("view", s); };
    render::ClientOptions co;
    co.budget_bytes = static_cast<uint64_t>(opt.budget_mb * 1024 * 1024);
    co.speed_limit_mps = opt.speed_limit;
    co.tau_speed_mps = opt.tau_speed;
    co.loader.ram_budget_bytes =
        opt.ram_budget_mb < 0 ? 2 * co.budget_bytes : static_cast<uint64_t>(opt.ram_budget_mb * 1024 * 1024);
    co.selection.tau = opt.tau;
    co.selection.priority = opt.priority == "view" ? render::PriorityMode::ViewWeighted : render::PriorityMode::Distance;
    co.selection.blockmaps = opt.blockmaps == "on";
    co.mode = opt.mode == "original" ? render::TextureMode::Original
              : opt.mode == "dummy"  ? render::TextureMode::Dummy
                                     : render::TextureMode::AtlasTree;
    // The window (and its GL context) first: it must outlive the client, which frees GL objects.
    Status st;
    render::Window::Options wo;
    wo.vsync = !opt.no_vsync;
    auto window = render::Window::create(opt.width, opt.height, "cityatlas view: " + opt.source, wo, &st);
    if (!window) return fail(st);
    auto client = render::StreamingClient::open(opt.source, co, &st);
    if (!client) return fail(st);
    if (Status gs = client->initGl(); !gs.ok()) return fail(gs);
    int computed_shown = -1, computed_mode = opt.computed_mode == "modulate" ? 2 : opt.computed_mode == "emphasis" ? 3 : 1;
    float computed_range[2] = {0.3F, 1.0F};
    render::EdgeStyle edges;  // edge enhancement, off until its checkbox
    if (!opt.computed.empty()) {
        const std::vector<std::string>& names = client->index().computed;
        const auto it = std::find(names.begin(), names.end(), opt.computed);
        if (it == names.end())
            return fail(Status::Usage(fmt::format("--computed {}: {} has {}", opt.computed, opt.source,
                                                  names.empty() ? std::string("no computed textures")
                                                                : fmt::format("only {}", fmt::join(names, ", ")))));
        computed_shown = static_cast<int>(it - names.begin());
    }

    const Box3d& bounds = client->index().nodes[0].bounds;
    Navigation nav;
    const render::CameraSample start = render::sampleFrame(render::defaultPath(bounds), 0);
    nav.camera.position = start.position;
    nav.camera.vertical_fov_deg = 60;
    nav.setDirection(start.direction);
    nav.pivot = 0.5 * (bounds.min + bounds.max);
    nav.floor_z = bounds.min.z;

    window->on_scroll = [&](double, double dy) {
        const Vec3d to = nav.pivot - nav.camera.position;
        nav.camera.position = nav.camera.position + (dy > 0 ? 0.15 : -0.15) * to;
    };
    auto overlay = render::Overlay::create(*window, &st);
    if (!overlay) return fail(st);

    // Frames are drawn offscreen and blitted to the window: the target's id
    // buffer is what a click picks from (the last frame shown, one pixel
    // read back instead of a ray cast over every drawn triangle), and the
    // window's default framebuffer need not be sRGB-capable.
    std::unique_ptr<render::OffscreenTarget> target;
    float tau = static_cast<float>(opt.tau);
    float budget_mb = static_cast<float>(opt.budget_mb);
    int mode = static_cast<int>(co.mode);
    double fps = 0;
    auto last = Clock::now();
    render::FrameRecord rec;
    uint64_t loaded_total = 0;
    std::string picked, picked_record;
    // The lens panel: the building of interest is the last one clicked.
    int64_t picked_feature = -1;
    int occlusion = 0;
    bool solo = false, by_height = false, sphere = false;
    float xray_falloff = 0.5F, sphere_radius = 40.0F, near_radius = 0.0F;
    int near_test = 0;  // render::NearTest
    int frame_count = 0;
    Vec3d last_position = nav.camera.position;
    while (!window->shouldClose() && (opt.frames == 0 || frame_count++ < opt.frames)) {
        window->pollEvents();
        const auto now = Clock::now();
        const double dt = std::min(0.1, std::chrono::duration<double>(now - last).count());
        last = now;
        fps = 0.9 * fps + 0.1 * (dt > 0 ? 1.0 / dt : 0);

        // Navigation (unless the overlay has the input).
        const auto [mx, my] = window->cursorPosition();
        const bool left = window->mouseButtonDown(GLFW_MOUSE_BUTTON_LEFT) && !overlay->wantsMouse();
        const bool right = window->mouseButtonDown(GLFW_MOUSE_BUTTON_RIGHT) && !overlay->wantsMouse();
        const double dx = mx - nav.last_x, dy = my - nav.last_y;
        nav.last_x = mx;
        nav.last_y = my;
        if (right && nav.dragging_right) {
            nav.yaw += dx * 0.004;
            nav.pitch -= dy * 0.004;
            nav.apply();
        }
        if (left && nav.dragging_left) {
            // Orbit around the pivot: turn the offset, then look at the pivot.
            const Vec3d off = nav.camera.position - nav.pivot;
            const double r = length(off);
            double a = std::atan2(off.y, off.x) - dx * 0.005;
            double e = std::asin(std::clamp(off.z / std::max(r, 1e-9), -1.0, 1.0)) + dy * 0.005;
            e = std::clamp(e, 0.02, 1.5);
            nav.camera.position = nav.pivot + r * Vec3d{std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
            nav.setDirection(nav.pivot - nav.camera.position);
        }
        // A click (press and release without dragging) picks the building under the cursor.
        if (left && !nav.dragging_left) {
            nav.press_x = mx;
            nav.press_y = my;
        }
        if (!left && nav.dragging_left && std::hypot(mx - nav.press_x, my - nav.press_y) < 4) {
            // Cursor coordinates are window units; the camera is in framebuffer pixels.
            const int fbw = window->framebufferSize().first;
            int ww = 0, wh = 0;
            glfwGetWindowSize(window->handle(), &ww, &wh);
            const double scale = ww > 0 ? static_cast<double>(fbw) / ww : 1.0;
            const uint32_t feature = target ? target->idAt(static_cast<int>(mx * scale), static_cast<int>(my * scale))
                                            : render::OffscreenTarget::kNoFeature;
            const bool hit = feature != render::OffscreenTarget::kNoFeature;
            picked = hit ? fmt::format("building {}", feature) : "nothing there";
            if (hit) picked_feature = feature;
            picked_record.clear();
            if (hit) {
                std::string record;
                const Status rs = client->featureRecord(feature, &record);
                picked_record = rs.ok() ? record : rs.error;
            }
        }
        nav.dragging_left = left;
        nav.dragging_right = right;
        if (!overlay->wantsKeyboard()) {
            const double v = nav.speed() * dt * (window->keyDown(GLFW_KEY_LEFT_SHIFT) ? 4.0 : 1.0);
            const Vec3d fwd = nav.camera.direction;
            const Vec3d side = render::normalized(cross(fwd, Vec3d{0, 0, 1}));
            Vec3d move{0, 0, 0};
            if (window->keyDown(GLFW_KEY_W)) move = move + fwd;
            if (window->keyDown(GLFW_KEY_S)) move = move - fwd;
            if (window->keyDown(GLFW_KEY_D)) move = move + side;
            if (window->keyDown(GLFW_KEY_A)) move = move - side;
            if (window->keyDown(GLFW_KEY_E)) move = move + Vec3d{0, 0, 1};
            if (window->keyDown(GLFW_KEY_Q)) move = move - Vec3d{0, 0, 1};
            if (length(move) > 0) nav.camera.position = nav.camera.position + v * render::normalized(move);
            nav.camera.position.z = std::max(nav.camera.position.z, nav.floor_z + 1.0);
            if (window->keyDown(GLFW_KEY_ESCAPE)) window->setShouldClose(true);
        }

        const auto [fw, fh] = window->framebufferSize();
        if (fw <= 0 || fh <= 0) continue;  // minimised
        nav.camera.width_px = fw;
        nav.camera.height_px = fh;
        if (!target || target->width() != fw || target->height() != fh) {
            target = render::OffscreenTarget::create(fw, fh, &st, /*with_ids=*/true);
            if (!target) return fail(st);
        }
        target->bind();
        // The camera's speed over the last frame, for the speed policies.
        client->setCameraVelocity(dt > 0 ? (1.0 / dt) * (nav.camera.position - last_position) : Vec3d{0, 0, 0});
        last_position = nav.camera.position;
        client->setEdges(edges, target.get());  // this frame's target (recreated on a resize)
        rec = client->frame(nav.camera);
        loaded_total += rec.bytes_loaded;
        target->blitToDefault(fw, fh);
        render::bindDefaultFramebuffer(fw, fh);

        overlay->newFrame();
        ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
        ImGui::Begin("cityatlas");
        ImGui::Text("%.1f fps, frame %.1f ms", fps, rec.frame_ms);
        ImGui::Text("nodes %u atlas, %u originals, %u blockmap, %u coarse", rec.nodes_atlas, rec.nodes_originals,
                    rec.nodes_blockmap, rec.nodes_coarse);
        ImGui::Text("texture binds %u, draw calls %u, %u triangles", rec.texture_binds, rec.draw_calls, rec.triangles);
        ImGui::Text("resident %s + %s bounds of %s (GPU %s)", humanBytes(rec.resident_bytes).c_str(),
                    humanBytes(rec.pinned_bytes).c_str(), humanBytes(rec.budget_bytes).c_str(), humanBytes(rec.gpu_bytes).c_str());
        ImGui::Text("queue %u, ideal set %u blocks, %u missing (%u needed)", rec.requests_in_flight, rec.ideal_blocks,
                    rec.ideal_missing, rec.needed_missing);
        ImGui::Text("loaded %s, errors %llu", humanBytes(loaded_total).c_str(), static_cast<unsigned long long>(rec.errors));
        ImGui::Text("RAM level %s of %s", humanBytes(rec.ram_bytes).c_str(), humanBytes(rec.ram_budget_bytes).c_str());
        if (!client->errors().empty()) ImGui::TextWrapped("last error: %s", client->errors().back().c_str());
        if (ImGui::SliderFloat("tau", &tau, 0.25F, 8.0F, "%.2f px/texel")) client->setTau(tau);
        if (ImGui::SliderFloat("budget MB", &budget_mb, 16.0F, 8192.0F, "%.0f")) {
            const uint64_t bytes = static_cast<uint64_t>(budget_mb) << 20;
            if (render::BlockManager::checkBudget(client->index(), bytes).ok()) client->setBudget(bytes);
        }
        ImGui::RadioButton("atlas tree", &mode, 0);
        ImGui::SameLine();
        ImGui::RadioButton("original", &mode, 1);
        ImGui::SameLine();
        ImGui::RadioButton("dummy", &mode, 2);
        client->setMode(static_cast<render::TextureMode>(mode));
        ImGui::Checkbox("edges", &edges.enabled);
        if (edges.enabled) {
            ImGui::SameLine();
            ImGui::SliderFloat("strength", &edges.strength, 0.0F, 1.0F, "%.2f");
        }
        // Computed textures (issue 19): which one, and how; the photo stands in until its blocks arrive.
        const std::vector<std::string>& computed_names = client->index().computed;
        if (!computed_names.empty()) {
            ImGui::Separator();
            const char* current = computed_shown < 0 ? "photo" : computed_names[static_cast<size_t>(computed_shown)].c_str();
            if (ImGui::BeginCombo("computed", current)) {
                if (ImGui::Selectable("photo", computed_shown < 0)) computed_shown = -1;
                for (size_t k = 0; k < computed_names.size(); ++k)
                    if (ImGui::Selectable(computed_names[k].c_str(), computed_shown == static_cast<int>(k)))
                        computed_shown = static_cast<int>(k);
                ImGui::EndCombo();
            }
            ImGui::RadioButton("ramp", &computed_mode, 1);
            ImGui::SameLine();
            ImGui::RadioButton("modulate", &computed_mode, 2);
            ImGui::SameLine();
            ImGui::RadioButton("emphasis", &computed_mode, 3);
            if (computed_mode >= 2) ImGui::SliderFloat2("b_min, b_max", computed_range, 0.0F, 2.0F, "%.2f");
            ImGui::Text("drawn with the photo meanwhile: %u node layers", rec.computed_missing_draws);
            render::ComputedStyle style{static_cast<render::ComputedMode>(computed_mode), computed_range[0],
                                        std::max(computed_range[0], computed_range[1])};
            client->setComputed(computed_shown, style);
        }
        ImGui::Text("height %.1f m, speed %.0f m/s (shift x4)", nav.camera.position.z - nav.floor_z, nav.speed());
        ImGui::TextWrapped("WASD move, Q/E down/up, right drag look, left drag orbit, click pick, wheel zoom, Esc quit");
        if (!picked.empty()) {
            ImGui::Separator();
            ImGui::TextUnformatted(picked.c_str());
            if (!picked_record.empty()) ImGui::TextUnformatted(picked_record.c_str());
        }
        // Lenses (papers/003): around the building last clicked.
        ImGui::Separator();
        ImGui::Text("lenses%s", picked_feature < 0 ? " (click a building first)" : "");
        ImGui::RadioButton("no occlusion lens", &occlusion, 0);
        ImGui::RadioButton("discard occluders", &occlusion, 1);
        ImGui::SameLine();
        ImGui::RadioButton("x-ray", &occlusion, 2);
        ImGui::SameLine();
        ImGui::RadioButton("flatten", &occlusion, 3);
        if (occlusion == 2) ImGui::SliderFloat("x-ray fall-off", &xray_falloff, 0.05F, 1.0F, "%.2f");
        if (occlusion != 0) {
            ImGui::SliderFloat("also near me, m", &near_radius, 0.0F, 200.0F, "%.0f");
            ImGui::RadioButton("sphere", &near_test, 0);
            ImGui::SameLine();
            ImGui::RadioButton("cylinder", &near_test, 1);
            ImGui::SameLine();
            ImGui::RadioButton("eye level", &near_test, 2);
        }
        ImGui::Checkbox("solo", &solo);
        ImGui::SameLine();
        ImGui::Checkbox("colour by height", &by_height);
        ImGui::SameLine();
        ImGui::Checkbox("sphere lens", &sphere);
        if (sphere) ImGui::SliderFloat("radius m", &sphere_radius, 5.0F, 1000.0F, "%.0f");
        {
            render::LensParams lens;
            lens.poi = picked_feature;
            const bool poi = picked_feature >= 0 && static_cast<size_t>(picked_feature) < client->featureBounds().size();
            if (poi) {
                lens.occlusion = static_cast<render::LensParams::Occlusion>(occlusion);
                lens.solo = solo;
                lens.highlight = {static_cast<uint32_t>(picked_feature)};
            }
            lens.xray_falloff = xray_falloff;
            lens.sphere_radius_m = near_radius;
            lens.near_test = static_cast<render::NearTest>(near_test);
            if (by_height) lens.colour_by = "height";
            if (sphere && poi) {
                const format::FeatureBoundsRecord& b = client->featureBounds()[static_cast<size_t>(picked_feature)];
                lens.shape = 1;
                lens.centre = {0.5 * (b.min[0] + b.max[0]), 0.5 * (b.min[1] + b.max[1]), 0.5 * (b.min[2] + b.max[2])};
                lens.radius_m = sphere_radius;
            }
            client->setLens(lens);
            if (rec.lens_occluders > 0) ImGui::Text("%u buildings styled", rec.lens_occluders);
        }
        ImGui::End();
        overlay->render();
        window->swapBuffers();
    }
    return kExitOk;
}

}  // namespace

RunFn addViewCommand(CLI::App& app) {
    auto opt = std::make_shared<ViewCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "view",
        "Fly through a tile folder or URL in a window, streaming blocks under a memory budget: WASD + mouse\n"
        "(fly), left drag (orbit), wheel (zoom); an overlay shows fps, nodes, texture binds, resident bytes and\n"
        "errors, with sliders for tau and the budget and a switch between atlas tree, original and dummy textures.\n"
        "Needs a display (use `cityatlas render` headless).");
    cmd->add_option("source", opt->source, "Tile folder (holding tileset.json) or http(s):// URL of one")->required();
    cmd->add_option("--width", opt->width, "Window width")->default_val(1600)->check(CLI::Range(64, 16384));
    cmd->add_option("--height", opt->height, "Window height")->default_val(900)->check(CLI::Range(64, 16384));
    cmd->add_option("--budget-mb", opt->budget_mb, "Memory budget for resident blocks, MiB")->default_val(512)
        ->check(CLI::Range(1.0, 1e6));
    cmd->add_option("--ram-budget-mb", opt->ram_budget_mb,
                    "The RAM level below the budget (block bytes kept after the GPU lets them go), MiB; 0: off; "
                    "default twice --budget-mb")
        ->check(CLI::Range(0.0, 1e7));
    cmd->add_option("--speed-limit", opt->speed_limit,
                    "While flying faster than this (m/s), request only blocks on screen at atlas levels; 0: off")
        ->check(CLI::Range(0.0, 1e9));
    cmd->add_option("--tau-speed", opt->tau_speed, "tau grows to tau * max(1, speed / K) while moving; K in m/s, 0: off")
        ->check(CLI::Range(0.0, 1e9));
    cmd->add_option("--tau", opt->tau, "Pixels per texel accepted")->default_val(1.0)->check(CLI::Range(0.1, 64.0));
    cmd->add_option("--mode", opt->mode, "atlas, original or dummy")->default_val("atlas")
        ->check(CLI::IsMember({"atlas", "original", "dummy"}));
    cmd->add_option("--blockmaps", opt->blockmaps,
                    "on or off: draw the folder's BlockMaps (build --blockmaps; off is refused on a folder built with "
                    "--blockmaps replace, whose upper levels are BlockMaps alone)")
        ->default_val("on")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option("--priority", opt->priority, "distance or view")->default_val("distance")
        ->check(CLI::IsMember({"distance", "view"}));
    cmd->add_option("--computed", opt->computed,
                    "Show this computed texture from the start (build --computed; the window's 'computed' list switches)");
    cmd->add_option("--computed-mode", opt->computed_mode, "ramp, modulate or emphasis")->default_val("ramp")
        ->check(CLI::IsMember({"ramp", "modulate", "emphasis"}));
    cmd->add_flag("--no-vsync", opt->no_vsync, "Draw as fast as possible (for measuring)");
    cmd->add_option("--frames", opt->frames, "Close after this many frames (0: when the window is closed)")
        ->default_val(0)
        ->check(CLI::Range(0, 100000000));
    return [opt]() { return runView(*opt); };
}

}  // namespace cityatlas::cli
