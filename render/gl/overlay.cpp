// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/gl/overlay.h"

#include <epoxy/gl.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

namespace cityatlas::render {
namespace {
bool g_overlay_alive = false;  // ImGui's backends are process-global
}  // namespace

std::unique_ptr<Overlay> Overlay::create(Window& window, Status* status) {
    if (g_overlay_alive) {
        *status = Status::Internal("overlay: one ImGui overlay exists already");
        return nullptr;
    }
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the working folder
    ImGui::StyleColorsDark();
    if (!ImGui_ImplGlfw_InitForOpenGL(window.handle(), true)) {
        ImGui::DestroyContext();
        *status = Status::Unsupported("overlay: ImGui's GLFW backend did not start");
        return nullptr;
    }
    if (!ImGui_ImplOpenGL3_Init("#version 330 core")) {
        ImGui_ImplGlfw_Shutdown();
        ImGui::DestroyContext();
        *status = Status::Unsupported("overlay: ImGui's OpenGL 3 backend did not start");
        return nullptr;
    }
    g_overlay_alive = true;
    *status = Status::Ok();
    return std::unique_ptr<Overlay>(new Overlay());
}

Overlay::~Overlay() {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    g_overlay_alive = false;
}

void Overlay::newFrame() {
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
}

void Overlay::render() {
    ImGui::Render();
    const GLboolean srgb = glIsEnabled(GL_FRAMEBUFFER_SRGB);
    glDisable(GL_FRAMEBUFFER_SRGB);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (srgb == GL_TRUE) glEnable(GL_FRAMEBUFFER_SRGB);
}

bool Overlay::wantsMouse() const { return ImGui::GetIO().WantCaptureMouse; }
bool Overlay::wantsKeyboard() const { return ImGui::GetIO().WantCaptureKeyboard; }

}  // namespace cityatlas::render
