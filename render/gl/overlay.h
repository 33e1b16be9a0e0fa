// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Dear ImGui on a Window (GLFW + OpenGL3 backends): statistics and controls
/// drawn over the city by `cityatlas view`. One overlay at a time (ImGui's
/// backends keep global state).

#include <memory>

#include "core/status.h"
#include "render/gl/gl_context.h"

namespace cityatlas::render {

class Overlay {
public:
    /// Initialises ImGui for `window` (its context must be current). Install
    /// the Window's input callbacks first: ImGui chains to them. Fails (nullptr,
    /// one line) when an overlay exists already or a backend cannot start.
    static std::unique_ptr<Overlay> create(Window& window, Status* status);
    ~Overlay();
    Overlay(const Overlay&) = delete;
    Overlay& operator=(const Overlay&) = delete;

    /// Starts an ImGui frame: call ImGui:: widgets between this and render().
    void newFrame();
    /// Draws the frame's widgets into the bound framebuffer. ImGui's colours
    /// are sRGB values already, so GL_FRAMEBUFFER_SRGB is off while it draws.
    void render();
    /// True when ImGui uses the mouse / keyboard this frame (the viewer's
    /// camera controls should then ignore them).
    bool wantsMouse() const;
    bool wantsKeyboard() const;

private:
    Overlay() = default;
};

}  // namespace cityatlas::render
