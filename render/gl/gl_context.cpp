// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/gl/gl_context.h"

#include <cstdlib>
#include <map>
#include <mutex>
#include <string_view>

#include <epoxy/egl.h>
#include <epoxy/gl.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <fmt/format.h>

namespace cityatlas::render {
namespace {

// ---------------------------------------------------------------- EGL

bool hasToken(const char* list, std::string_view token) {
    if (list == nullptr) return false;
    std::string_view rest(list);
    while (!rest.empty()) {
        const size_t space = rest.find(' ');
        const std::string_view word = rest.substr(0, space);
        if (word == token) return true;
        if (space == std::string_view::npos) break;
        rest.remove_prefix(space + 1);
    }
    return false;
}

std::string eglErrorName(EGLint error) {
    switch (error) {
        case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
        case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
        case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
        case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
        default: return fmt::format("0x{:04x}", error);
    }
}

// eglGetPlatformDisplayEXT hands out one EGLDisplay per platform and device,
// and eglTerminate ends it for every user: count our contexts per display so
// one HeadlessContext going away does not pull the display from under another.
std::mutex g_display_mutex;
std::map<EGLDisplay, int> g_display_users;

void releaseDisplay(EGLDisplay display) {
    const std::lock_guard<std::mutex> lock(g_display_mutex);
    if (--g_display_users[display] <= 0) {
        g_display_users.erase(display);
        eglTerminate(display);
    }
}

// The surfaceless platform first (Mesa: no display, no /dev/dri needed); the
// device platform as the fallback (also Mesa's software device, and NVIDIA's
// headless path).
EGLDisplay openDisplay(std::string* platform, std::string* error) {
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (client == nullptr || !hasToken(client, "EGL_EXT_platform_base")) {
        *error = "EGL: no EGL_EXT_platform_base (install libegl1 and libegl-mesa0)";
        return EGL_NO_DISPLAY;
    }
    if (hasToken(client, "EGL_MESA_platform_surfaceless")) {
        EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
        if (d != EGL_NO_DISPLAY) {
            *platform = "surfaceless";
            return d;
        }
    }
    if (hasToken(client, "EGL_EXT_platform_device") && hasToken(client, "EGL_EXT_device_enumeration")) {
        EGLDeviceEXT device = nullptr;
        EGLint count = 0;
        if (eglQueryDevicesEXT(1, &device, &count) && count > 0) {
            EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, device, nullptr);
            if (d != EGL_NO_DISPLAY) {
                *platform = "device";
                return d;
            }
        }
        *error = "EGL: no surfaceless platform and no EGL device (install libegl-mesa0)";
        return EGL_NO_DISPLAY;
    }
    *error = "EGL: no surfaceless platform (install libegl-mesa0)";
    return EGL_NO_DISPLAY;
}

}  // namespace

std::unique_ptr<HeadlessContext> HeadlessContext::create(Status* status) {
    std::string platform, error;
    EGLDisplay display = openDisplay(&platform, &error);
    if (display == EGL_NO_DISPLAY) {
        *status = Status::Unsupported(error);
        return nullptr;
    }
    EGLint egl_major = 0, egl_minor = 0;
    {
        const std::lock_guard<std::mutex> lock(g_display_mutex);
        if (!eglInitialize(display, &egl_major, &egl_minor)) {
            *status = Status::Unsupported(fmt::format("EGL: eglInitialize on the {} platform failed ({})", platform,
                                               eglErrorName(eglGetError())));
            return nullptr;
        }
        ++g_display_users[display];
    }
    std::unique_ptr<HeadlessContext> ctx(new HeadlessContext());
    ctx->display_ = display;
    ctx->platform_ = platform;
    auto fail = [&](const std::string& what) {
        *status = Status::Unsupported(fmt::format("EGL: {} ({})", what, eglErrorName(eglGetError())));
        return nullptr;
    };

    if (!eglBindAPI(EGL_OPENGL_API)) return fail("desktop OpenGL is not available through EGL");

    const char* display_ext = eglQueryString(display, EGL_EXTENSIONS);
    const bool surfaceless = hasToken(display_ext, "EGL_KHR_surfaceless_context");
    const EGLint config_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                     EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint configs = 0;
    if (!eglChooseConfig(display, config_attribs, &config, 1, &configs) || configs < 1) {
        // We render into FBOs only; a context without a config is just as good.
        if (!surfaceless || !hasToken(display_ext, "EGL_KHR_no_config_context"))
            return fail("no OpenGL-renderable config");
        config = EGL_NO_CONFIG_KHR;
    }
    const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 3,
                                      EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                      EGL_NONE};
    EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
    if (context == EGL_NO_CONTEXT) return fail("no OpenGL 3.3 core context");
    ctx->context_ = context;
    if (!surfaceless) {
        const EGLint pbuffer_attribs[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
        EGLSurface surface = eglCreatePbufferSurface(display, config, pbuffer_attribs);
        if (surface == EGL_NO_SURFACE) return fail("no surfaceless contexts and no pbuffer");
        ctx->surface_ = surface;
    }
    if (!ctx->makeCurrent()) return fail("eglMakeCurrent failed");
    *status = Status::Ok();
    return ctx;
}

HeadlessContext::~HeadlessContext() {
    if (display_ == nullptr) return;
    EGLDisplay display = display_;
    if (eglGetCurrentContext() == context_) eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    if (surface_ != nullptr) eglDestroySurface(display, surface_);
    if (context_ != nullptr) eglDestroyContext(display, context_);
    releaseDisplay(display);
}

bool HeadlessContext::makeCurrent() {
    EGLSurface surface = surface_ != nullptr ? surface_ : EGL_NO_SURFACE;
    return eglMakeCurrent(display_, surface, surface, context_) == EGL_TRUE;
}

// ---------------------------------------------------------------- GL info

GlInfo queryGlInfo() {
    GlInfo info;
    auto str = [](GLenum name) {
        const auto* s = reinterpret_cast<const char*>(glGetString(name));
        return std::string(s != nullptr ? s : "");
    };
    info.vendor = str(GL_VENDOR);
    info.renderer = str(GL_RENDERER);
    info.version = str(GL_VERSION);
    glGetIntegerv(GL_MAJOR_VERSION, &info.major);
    glGetIntegerv(GL_MINOR_VERSION, &info.minor);
    GLint profile = 0;
    glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
    info.core_profile = (profile & GL_CONTEXT_CORE_PROFILE_BIT) != 0;
    // epoxy reads the extension list with glGetStringi in core profiles.
    info.s3tc = epoxy_has_gl_extension("GL_EXT_texture_compression_s3tc");
    info.srgb_s3tc = info.s3tc && (epoxy_has_gl_extension("GL_EXT_texture_sRGB") ||
                                   epoxy_has_gl_extension("GL_EXT_texture_compression_s3tc_srgb"));
    info.anisotropic = epoxy_has_gl_extension("GL_EXT_texture_filter_anisotropic") ||
                       epoxy_has_gl_extension("GL_ARB_texture_filter_anisotropic");
    if (info.anisotropic) glGetFloatv(GL_MAX_TEXTURE_MAX_ANISOTROPY, &info.max_anisotropy);
    return info;
}

// ---------------------------------------------------------------- GLFW window

namespace {

// GLFW reports errors through a callback; keep the last one for the Status.
std::string g_glfw_error;
int g_glfw_windows = 0;  // glfwInit/glfwTerminate bracket the open windows

void onGlfwError(int code, const char* description) {
    g_glfw_error = fmt::format("GLFW error 0x{:x}: {}", code, description != nullptr ? description : "");
}

Window* windowOf(GLFWwindow* w) { return static_cast<Window*>(glfwGetWindowUserPointer(w)); }

}  // namespace

std::unique_ptr<Window> Window::create(int width, int height, const std::string& title, Status* status) {
    return create(width, height, title, Options{}, status);
}

std::unique_ptr<Window> Window::create(int width, int height, const std::string& title, const Options& options,
                                       Status* status) {
    const char* x11 = std::getenv("DISPLAY");
    const char* wayland = std::getenv("WAYLAND_DISPLAY");
    if ((x11 == nullptr || *x11 == '\0') && (wayland == nullptr || *wayland == '\0')) {
        *status = Status::Unsupported("no display: use `cityatlas render` for headless rendering, or run under xvfb-run");
        return nullptr;
    }
    if (width <= 0 || height <= 0) {
        *status = Status::Usage(fmt::format("window: size {}x{} is not positive", width, height));
        return nullptr;
    }
    glfwSetErrorCallback(onGlfwError);
    if (g_glfw_windows == 0 && glfwInit() != GLFW_TRUE) {
        *status = Status::Unsupported(fmt::format("no display: {} (use `cityatlas render` for headless rendering, or run "
                                           "under xvfb-run)", g_glfw_error));
        return nullptr;
    }
    glfwDefaultWindowHints();
    glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_SRGB_CAPABLE, options.srgb ? GLFW_TRUE : GLFW_FALSE);
    glfwWindowHint(GLFW_DEPTH_BITS, 24);
    glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
    GLFWwindow* handle = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (handle == nullptr) {
        *status = Status::Unsupported(fmt::format("window: no OpenGL 3.3 core window ({})", g_glfw_error));
        if (g_glfw_windows == 0) glfwTerminate();
        return nullptr;
    }
    ++g_glfw_windows;
    std::unique_ptr<Window> window(new Window());
    window->window_ = handle;
    glfwSetWindowUserPointer(handle, window.get());
    glfwMakeContextCurrent(handle);
    glfwSwapInterval(options.vsync ? 1 : 0);

    if (options.srgb) {
        GLint encoding = GL_LINEAR;
        glGetFramebufferAttachmentParameteriv(GL_FRAMEBUFFER, GL_BACK_LEFT,
                                              GL_FRAMEBUFFER_ATTACHMENT_COLOR_ENCODING, &encoding);
        window->srgb_framebuffer_ = glGetError() == GL_NO_ERROR && encoding == GL_SRGB;
    }

    glfwSetKeyCallback(handle, [](GLFWwindow* w, int key, int scancode, int action, int mods) {
        if (Window* self = windowOf(w); self != nullptr && self->on_key) self->on_key(key, scancode, action, mods);
    });
    glfwSetMouseButtonCallback(handle, [](GLFWwindow* w, int button, int action, int mods) {
        if (Window* self = windowOf(w); self != nullptr && self->on_mouse_button)
            self->on_mouse_button(button, action, mods);
    });
    glfwSetCursorPosCallback(handle, [](GLFWwindow* w, double x, double y) {
        if (Window* self = windowOf(w); self != nullptr && self->on_cursor) self->on_cursor(x, y);
    });
    glfwSetScrollCallback(handle, [](GLFWwindow* w, double dx, double dy) {
        if (Window* self = windowOf(w); self != nullptr && self->on_scroll) self->on_scroll(dx, dy);
    });
    glfwSetFramebufferSizeCallback(handle, [](GLFWwindow* w, int fw, int fh) {
        if (Window* self = windowOf(w); self != nullptr && self->on_framebuffer_size) self->on_framebuffer_size(fw, fh);
    });
    *status = Status::Ok();
    return window;
}

Window::~Window() {
    if (window_ == nullptr) return;
    glfwDestroyWindow(window_);
    if (--g_glfw_windows == 0) glfwTerminate();
}

void Window::makeCurrent() { glfwMakeContextCurrent(window_); }
void Window::pollEvents() { glfwPollEvents(); }
void Window::swapBuffers() { glfwSwapBuffers(window_); }
bool Window::shouldClose() const { return glfwWindowShouldClose(window_) == GLFW_TRUE; }
void Window::setShouldClose(bool close) { glfwSetWindowShouldClose(window_, close ? GLFW_TRUE : GLFW_FALSE); }
void Window::setTitle(const std::string& title) { glfwSetWindowTitle(window_, title.c_str()); }

std::pair<int, int> Window::framebufferSize() const {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window_, &w, &h);
    return {w, h};
}

bool Window::keyDown(int glfw_key) const { return glfwGetKey(window_, glfw_key) == GLFW_PRESS; }
bool Window::mouseButtonDown(int glfw_button) const {
    return glfwGetMouseButton(window_, glfw_button) == GLFW_PRESS;
}
std::pair<double, double> Window::cursorPosition() const {
    double x = 0, y = 0;
    glfwGetCursorPos(window_, &x, &y);
    return {x, y};
}

}  // namespace cityatlas::render
