// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Where OpenGL 3.3 core contexts come from: a headless EGL context (no
/// display, no GPU needed: Mesa llvmpipe through EGL surfaceless) for `cityatlas
/// render` and the tests, and a GLFW window for `cityatlas view`. GL entry
/// points are loaded through libepoxy, which follows whichever of the two is
/// current. ../shared/STACK.md, rows "OpenGL / EGL", "GLFW", "libepoxy".

#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "core/status.h"

struct GLFWwindow;

namespace cityatlas::render {

/// An OpenGL 3.3 core context with no surface: render into an
/// OffscreenTarget (gl_renderer.h). The display is
/// eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA), or the first
/// EGL_EXT_platform_device device when the surfaceless platform is missing.
class HeadlessContext {
public:
    /// Creates the context and makes it current on the calling thread. On
    /// failure returns nullptr and a one-line reason in *status (e.g. "EGL: no
    /// surfaceless platform (install libegl-mesa0)").
    static std::unique_ptr<HeadlessContext> create(Status* status);
    ~HeadlessContext();
    HeadlessContext(const HeadlessContext&) = delete;
    HeadlessContext& operator=(const HeadlessContext&) = delete;

    /// Makes the context current on the calling thread (a context is current on
    /// one thread at a time). False when EGL refuses.
    bool makeCurrent();
    /// "surfaceless" or "device": which EGL platform the display came from.
    const std::string& platform() const { return platform_; }

private:
    HeadlessContext() = default;
    void* display_ = nullptr;  ///< EGLDisplay (EGL types stay out of this header)
    void* context_ = nullptr;  ///< EGLContext
    void* surface_ = nullptr;  ///< EGLSurface: a 1x1 pbuffer only when EGL_KHR_surfaceless_context is missing
    std::string platform_;
};

/// What the current context offers. Needs a current context.
struct GlInfo {
    std::string vendor, renderer, version;
    int major = 0, minor = 0;        ///< the context's version (GL_MAJOR_VERSION, GL_MINOR_VERSION)
    bool core_profile = false;       ///< GL_CONTEXT_CORE_PROFILE_BIT set
    /// GL_EXT_texture_compression_s3tc in the extension list. Not taken from
    /// GL_COMPRESSED_TEXTURE_FORMATS: Mesa lists DXT5 there but not DXT1.
    bool s3tc = false;
    /// The sRGB S3TC formats (GL_EXT_texture_sRGB or
    /// GL_EXT_texture_compression_s3tc_srgb, on top of s3tc).
    bool srgb_s3tc = false;
    bool anisotropic = false;        ///< GL_EXT/ARB_texture_filter_anisotropic
    float max_anisotropy = 1;        ///< GL_MAX_TEXTURE_MAX_ANISOTROPY (1 without the extension)
};
GlInfo queryGlInfo();

/// A desktop window with an OpenGL 3.3 core context (GLFW). One thread: create,
/// poll and draw on the same thread (GLFW's rule for the main thread).
class Window {
public:
    struct Options {
        bool vsync = true;    ///< swap interval 1 (0: as fast as possible, for measurements)
        bool visible = true;  ///< false: an invisible window (smoke tests)
        bool srgb = true;     ///< ask for an sRGB-capable default framebuffer (see srgbFramebuffer())
    };

    /// Opens the window and makes its context current. Without a display
    /// returns nullptr and "no display: use `cityatlas render` for headless
    /// rendering, or run under xvfb-run"; other failures name GLFW's reason.
    static std::unique_ptr<Window> create(int width, int height, const std::string& title, Status* status);
    static std::unique_ptr<Window> create(int width, int height, const std::string& title, const Options& options,
                                          Status* status);
    ~Window();
    Window(const Window&) = delete;
    Window& operator=(const Window&) = delete;

    void makeCurrent();
    /// Processes pending events (calls the callbacks below) and returns at once.
    void pollEvents();
    void swapBuffers();
    bool shouldClose() const;
    void setShouldClose(bool close);
    void setTitle(const std::string& title);

    /// Framebuffer size in pixels (differs from the window size on HiDPI screens).
    std::pair<int, int> framebufferSize() const;
    /// Whether the default framebuffer encodes to sRGB with GL_FRAMEBUFFER_SRGB
    /// on: the renderer draws in linear light, so without it the picture is too
    /// dark; a caller can then render into an OffscreenTarget and blit.
    bool srgbFramebuffer() const { return srgb_framebuffer_; }

    /// Polled input state (GLFW key and button codes).
    bool keyDown(int glfw_key) const;
    bool mouseButtonDown(int glfw_button) const;
    std::pair<double, double> cursorPosition() const;  ///< window coordinates, pixels, origin top left

    /// Input callbacks, called from pollEvents(); any may be empty. Install
    /// them before an Overlay (ImGui chains to callbacks set before it).
    std::function<void(int key, int scancode, int action, int mods)> on_key;
    std::function<void(int button, int action, int mods)> on_mouse_button;
    std::function<void(double x, double y)> on_cursor;
    std::function<void(double dx, double dy)> on_scroll;
    std::function<void(int width, int height)> on_framebuffer_size;

    GLFWwindow* handle() const { return window_; }

private:
    Window() = default;
    GLFWwindow* window_ = nullptr;
    bool srgb_framebuffer_ = false;
};

}  // namespace cityatlas::render
