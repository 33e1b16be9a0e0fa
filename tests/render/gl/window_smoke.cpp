// SPDX-License-Identifier: GPL-3.0-or-later
// Window smoke test (run by window_smoke.sh under xvfb-run): a GLFW window with
// a 3.3 core context, the renderer drawing a material-coloured quad into its
// default framebuffer, the ImGui overlay on top, one swap. Checks the centre
// pixel against the material colour and exits 0, or prints one line and
// exits 1.
#include <cmath>
#include <cstdio>
#include <vector>

#include <epoxy/gl.h>
#include <imgui.h>

#include "render/gl/gl_context.h"
#include "render/gl/gl_renderer.h"
#include "render/gl/overlay.h"

using namespace cityatlas;
using namespace cityatlas::render;

namespace {
int fail(const std::string& message) {
    std::fprintf(stderr, "window_smoke: %s\n", message.c_str());
    return 1;
}
int srgbByte(double l) {
    const double s = l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1.0 / 2.4) - 0.055;
    return static_cast<int>(std::lround(s * 255));
}
}  // namespace

int main() {
    Status status;
    Window::Options options;
    options.visible = false;
    options.vsync = false;
    auto window = Window::create(96, 64, "cityatlas window smoke", options, &status);
    if (!window) return fail(status.error);
    int keys = 0;
    window->on_key = [&](int, int, int, int) { ++keys; };
    const GlInfo info = queryGlInfo();
    std::printf("window: %s | %s | sRGB framebuffer %s\n", info.renderer.c_str(), info.version.c_str(),
                window->srgbFramebuffer() ? "yes" : "no");
    if (info.major * 10 + info.minor < 33 || !info.core_profile) return fail("not a 3.3 core context: " + info.version);
    const auto [fw, fh] = window->framebufferSize();
    if (fw != 96 || fh != 64) return fail("framebuffer is " + std::to_string(fw) + "x" + std::to_string(fh));

    const double green = 0.6;
    auto renderer = GlRenderer::create({MaterialInfo{{0.05F, static_cast<float>(green), 0.05F}, 0}}, &status);
    if (!renderer) return fail(status.error);
    auto overlay = Overlay::create(*window, &status);
    if (!overlay) return fail(status.error);

    MeshData m;
    m.positions = {-5, 0, -5, 5, 0, -5, 5, 0, 5, -5, 0, 5};
    m.material_id = {0, 0, 0, 0};
    m.indices = {0, 1, 2, 0, 2, 3};
    GpuMesh mesh = renderer->upload(m, &status);
    if (!status.ok()) return fail(status.error);

    Camera camera;
    camera.width_px = fw;
    camera.height_px = fh;
    camera.direction = {0, 1, 0};
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    FrameStats stats;
    unsigned char px[4] = {0, 0, 0, 0}, corner[4] = {0, 0, 0, 0};
    // A few frames: ImGui hides a new auto-sized window on its first frame.
    for (int frame = 0; frame < 3; ++frame) {
        renderer->beginFrame(camera, {0, 0, 0, 1});
        renderer->drawAtlas(mesh, nullptr, {0, 2, 0}, 0);
        stats = renderer->endFrame();
        overlay->newFrame();
        ImGui::SetNextWindowPos(ImVec2(0, 0));
        ImGui::Begin("stats");
        ImGui::Text("draws %u", stats.draw_calls);
        ImGui::End();
        overlay->render();
        glReadBuffer(GL_BACK);
        glReadPixels(fw - 2, 1, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, px);          // bottom right: the city
        glReadPixels(2, fh - 2, 1, 1, GL_RGBA, GL_UNSIGNED_BYTE, corner);     // top left: ImGui's title bar
        if (frame + 1 < 3) window->swapBuffers();
    }
    window->swapBuffers();
    window->pollEvents();
    // With an sRGB framebuffer the stored bytes are srgb(material); without, the linear values.
    auto encode = [&](double l) {
        return window->srgbFramebuffer() ? srgbByte(l) : static_cast<int>(std::lround(l * 255));
    };
    const int want[3] = {encode(0.05), encode(green), encode(0.05)};
    for (int c = 0; c < 3; ++c) {
        if (std::abs(px[c] - want[c]) > 1)
            return fail("bottom right pixel is " + std::to_string(px[0]) + "," + std::to_string(px[1]) + "," +
                        std::to_string(px[2]) + ", expected " + std::to_string(want[0]) + "," +
                        std::to_string(want[1]) + "," + std::to_string(want[2]));
    }
    if (std::abs(corner[0] - px[0]) + std::abs(corner[1] - px[1]) + std::abs(corner[2] - px[2]) < 30)
        return fail("the overlay drew nothing at the top left");
    if (const GLenum e = glGetError(); e != GL_NO_ERROR) return fail("GL error " + std::to_string(e));
    renderer->release(&mesh);
    std::printf("window smoke: ok (%u draw calls, %d key events)\n", stats.draw_calls, keys);
    return 0;
}
