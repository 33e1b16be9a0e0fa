// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/gl/gl_renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include <epoxy/gl.h>
#include <fmt/format.h>

#include "render/gl/gl_context.h"
#include "render/gl/gl_program.h"
#include "render/gl/screen_door.h"
#include "format/dds.h"
#include "render/core/computed_ramp.h"

namespace cityatlas::render {
namespace {

// Attribute locations, fixed in the shader so VAOs need no program.
constexpr GLuint kPosition = 0, kUvAtlas = 1, kUvOriginal = 2, kMaterial = 3, kFeature = 4;

// Shader modes: what a fragment's colour comes from.
constexpr int kModeTextured = 0;  // material colour if material_id >= 0, else the texture
constexpr int kModeColours = 1;   // material colour if material_id >= 0, else the neutral grey
constexpr int kModeDummy = 2;     // the (dummy) texture everywhere

constexpr const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_uv_atlas;
layout(location = 2) in vec2 a_uv_original;
layout(location = 3) in int a_material;
layout(location = 4) in uint a_feature;
uniform mat4 u_view_projection;  // projection * viewRotation: no translation
uniform vec3 u_offset;           // node centre - camera position, computed in double
uniform int u_uv_set;            // 0: uv_atlas, 1: uv_original
uniform bool u_styled;           // per-feature lens styles are set (lenses.h)
uniform usamplerBuffer u_styles; // per feature: 0 normal, 1 discard, 2 x-ray, 3 flatten
uniform samplerBuffer u_bases;   // per feature: base z, local frame
uniform float u_flatten;         // flatten: z' = base + (z - base) * u_flatten
uniform float u_camera_z;        // the camera's z, local frame (bases are local)
out vec2 v_uv;
out vec2 v_uv_computed;          // uv_atlas, for the computed texture
out vec3 v_rel;                  // position relative to the camera (metres)
flat out int v_material;
flat out uint v_feature;
flat out uint v_style;
void main() {
    vec3 p = a_position + u_offset;
    v_style = 0u;
    if (u_styled && a_feature < uint(textureSize(u_styles))) v_style = texelFetch(u_styles, int(a_feature)).r;
    if (v_style == 3u) {
        float base = texelFetch(u_bases, int(a_feature)).r - u_camera_z;
        p.z = base + (p.z - base) * u_flatten;
    }
    v_rel = p;
    gl_Position = u_view_projection * vec4(p, 1.0);
    vec2 uv = u_uv_set == 1 ? a_uv_original : a_uv_atlas;
    v_uv = vec2(uv.x, 1.0 - uv.y);  // v = 0 at the image bottom; texture rows are stored top first
    v_uv_computed = vec2(a_uv_atlas.x, 1.0 - a_uv_atlas.y);
    v_material = a_material;
    v_feature = a_feature;
}
)";

constexpr const char* kFragmentShader = R"(#version 330 core
in vec2 v_uv;
in vec2 v_uv_computed;
uniform sampler2D u_computed;     // BC4: the node layer's computed texture
uniform sampler2D u_ramp;         // 256 x 1 sRGB: the colour ramp
uniform int u_computed_mode;      // 0 photo, 1 ramp, 2 modulate, 3 emphasis (ComputedMode)
uniform vec2 u_computed_range;    // modulate, emphasis: b_min, b_max
uniform vec4 u_emphasis;          // emphasis: the yellow (linear) and its weight at v = 1
flat in int v_material;
flat in uint v_feature;
flat in uint v_style;
in vec3 v_rel;
uniform sampler2D u_texture;
uniform int u_pass;               // 0: opaque, 1: alpha layer, 2: x-ray (features styled x-ray only)
uniform float u_xray_falloff;     // x-ray opacity 1 - |N.V|^e (papers/003 eq. 3.19)
uniform bool u_tinted;            // per-feature tint colours are set
uniform samplerBuffer u_tints;    // per feature: linear rgb and the mix weight
uniform int u_lens;               // analytic colour lens: 0 none, 1 sphere, 2 vertical cylinder
uniform vec3 u_lens_centre;       // relative to the camera
uniform float u_lens_radius;
uniform vec2 u_context;           // outside the lens: saturation, brightness
)" CITYATLAS_SCREEN_DOOR_GLSL R"(
uniform samplerBuffer u_materials;  // linear rgb, alpha = 1 - transparency
uniform int u_material_count;
uniform int u_mode;
uniform bool u_opaque;
uniform float u_grey;
layout(location = 0) out vec4 o_colour;
layout(location = 1) out uint o_feature;  // the id buffer, where the target has one
void main() {
    vec4 c;
    if (u_mode == 2) {
        c = texture(u_texture, v_uv);
    } else if (v_material >= 0) {
        c = v_material < u_material_count ? texelFetch(u_materials, v_material) : vec4(vec3(u_grey), 1.0);
    } else if (u_mode == 0) {
        c = texture(u_texture, v_uv);
        if (u_computed_mode != 0) {
            float v = texture(u_computed, v_uv_computed).r;
            if (u_computed_mode == 1) {
                c.rgb = texture(u_ramp, vec2((v * 255.0 + 0.5) / 256.0, 0.5)).rgb;
            } else {
                if (u_computed_mode == 3) c.rgb = mix(vec3(dot(c.rgb, vec3(0.2126, 0.7152, 0.0722))), c.rgb, v);
                c.rgb *= min(1.0, u_computed_range.x + v * (u_computed_range.y - u_computed_range.x));
                if (u_computed_mode == 3) c.rgb = mix(c.rgb, u_emphasis.rgb, u_emphasis.a * v);
            }
        }
    } else {
        c = vec4(vec3(u_grey), 1.0);
    }
    if (screenDoorDiscards()) discard;                 // the cross-fade (screen_door.h)
    if (v_style == 1u) discard;                        // the discard lens
    if ((v_style == 2u) != (u_pass == 2)) discard;      // x-ray faces only in their own pass
    if (u_tinted && v_feature < uint(textureSize(u_tints))) {
        vec4 t = texelFetch(u_tints, int(v_feature));
        c.rgb = mix(c.rgb, t.rgb, t.a);
    }
    if (u_lens != 0) {
        vec3 d = v_rel - u_lens_centre;
        float r = u_lens == 1 ? length(d) : length(d.xy);
        if (!(r < u_lens_radius)) {  // context: desaturated and darkened
            float grey = dot(c.rgb, vec3(0.2126, 0.7152, 0.0722));
            c.rgb = mix(vec3(grey), c.rgb, u_context.x) * u_context.y;
        }
    }
    float alpha = u_opaque ? 1.0 : c.a;
    if (u_pass == 2) {
        // The face's normal from the screen-space derivatives (tiles carry no normals).
        vec3 n = normalize(cross(dFdx(v_rel), dFdy(v_rel)));
        vec3 v = normalize(-v_rel);
        alpha = 1.0 - pow(abs(dot(n, v)), u_xray_falloff);
    }
    o_colour = vec4(c.rgb, alpha);
    o_feature = v_feature;
}
)";


void setStatus(Status* status, Status value) {
    if (status != nullptr) *status = std::move(value);
}

double elapsedMs(std::chrono::steady_clock::time_point since) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

// Column-major 4x4 product a * b, in double so the one rounding is at the end.
std::array<float, 16> multiply(const std::array<float, 16>& a, const std::array<float, 16>& b) {
    std::array<float, 16> m{};
    for (int c = 0; c < 4; ++c) {
        for (int r = 0; r < 4; ++r) {
            double s = 0;
            for (int k = 0; k < 4; ++k) s += static_cast<double>(a[k * 4 + r]) * b[c * 4 + k];
            m[c * 4 + r] = static_cast<float>(s);
        }
    }
    return m;
}

Status checkTexture(const CompressedTexture& t, GLint max_size) {
    if (t.channels != 3 && t.channels != 4 && t.channels != 1)
        return Status::Invalid(fmt::format("texture: {} channels (3: BC1, 4: BC3 or 1: BC4 expected)", t.channels));
    if (t.width < 1 || t.height < 1 || t.width > max_size || t.height > max_size)
        return Status::Invalid(fmt::format("texture: size {}x{} outside 1..{}", t.width, t.height, max_size));
    if (t.levels.empty()) return Status::Invalid("texture: no mip levels");
    int w = t.width, h = t.height;
    for (size_t i = 0; i < t.levels.size(); ++i) {
        const CompressedTexture::Level& level = t.levels[i];
        if (level.width != w || level.height != h)
            return Status::Invalid(fmt::format("texture: level {} is {}x{}, expected {}x{}", i, level.width,
                                            level.height, w, h));
        if (level.bytes != format::bcBlockBytes(w, h, t.channels))
            return Status::Invalid(fmt::format("texture: level {} has {} bytes, {}x{} BC{} needs {}", i, level.bytes, w,
                                            h, t.channels == 3 ? 1 : t.channels == 1 ? 4 : 3, format::bcBlockBytes(w, h, t.channels)));
        if (level.offset > t.data.size() || level.bytes > t.data.size() - level.offset)
            return Status::Invalid(fmt::format("texture: level {} lies outside the {} data bytes", i, t.data.size()));
        if (w == 1 && h == 1 && i + 1 < t.levels.size())
            return Status::Invalid("texture: levels continue past 1x1");
        w = std::max(1, w / 2);
        h = std::max(1, h / 2);
    }
    return Status::Ok();
}

Status checkMesh(const MeshData& m) {
    if (m.positions.size() % 3 != 0) return Status::Invalid("mesh: positions are not xyz triples");
    const size_t n = m.positions.size() / 3;
    if (n > std::numeric_limits<uint32_t>::max()) return Status::Invalid("mesh: more than 2^32 - 1 vertices");
    if (!m.uv_atlas.empty() && m.uv_atlas.size() != 2 * n)
        return Status::Invalid(fmt::format("mesh: {} uv_atlas values for {} vertices", m.uv_atlas.size(), n));
    if (!m.uv_original.empty() && m.uv_original.size() != 2 * n)
        return Status::Invalid(fmt::format("mesh: {} uv_original values for {} vertices", m.uv_original.size(), n));
    if (!m.material_id.empty() && m.material_id.size() != n)
        return Status::Invalid(fmt::format("mesh: {} material ids for {} vertices", m.material_id.size(), n));
    if (!m.feature_id.empty() && m.feature_id.size() != n)
        return Status::Invalid(fmt::format("mesh: {} feature ids for {} vertices", m.feature_id.size(), n));
    if (m.indices.size() % 3 != 0) return Status::Invalid("mesh: index count is not a multiple of 3");
    if (m.indices.size() > std::numeric_limits<uint32_t>::max()) return Status::Invalid("mesh: too many indices");
    for (size_t i = 0; i < m.indices.size(); ++i) {
        if (m.indices[i] >= n)
            return Status::Invalid(fmt::format("mesh: index {} is {}, only {} vertices", i, m.indices[i], n));
    }
    for (const MeshData::TextureRange& r : m.texture_ranges) {
        if (r.first_index > m.indices.size() || r.index_count > m.indices.size() - r.first_index)
            return Status::Invalid(fmt::format("mesh: texture {} range [{}, +{}) outside the {} indices", r.texture,
                                            r.first_index, r.index_count, m.indices.size()));
    }
    return Status::Ok();
}

void setSampling(bool wrap, bool anisotropic, float anisotropy, int levels) {
    const GLint mode = wrap ? GL_REPEAT : GL_CLAMP_TO_EDGE;
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, mode);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, mode);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_BASE_LEVEL, 0);
    // A chain may stop before 1x1: the texture is complete with the levels it has.
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, levels - 1);
    if (anisotropic) glTexParameterf(GL_TEXTURE_2D, GL_TEXTURE_MAX_ANISOTROPY, anisotropy);
}

}  // namespace

// ---------------------------------------------------------------- OffscreenTarget

namespace {
// GL's first row is the bottom one; callers get images in file order (rows of `row` values).
template <class T>
void topDown(const std::vector<T>& bottom_up, size_t row, int height, std::vector<T>* out) {
    out->resize(bottom_up.size());
    for (int y = 0; y < height; ++y) std::copy_n(bottom_up.data() + row * (height - 1 - y), row, out->data() + row * y);
}
}  // namespace

std::unique_ptr<OffscreenTarget> OffscreenTarget::create(int width, int height, Status* status, bool with_ids) {
    GLint max_size = 0;
    glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_size);
    if (width < 1 || height < 1 || width > max_size || height > max_size) {
        *status = Status::Unsupported(fmt::format("offscreen target: size {}x{} outside 1..{}", width, height, max_size));
        return nullptr;
    }
    std::unique_ptr<OffscreenTarget> t(new OffscreenTarget());
    t->width_ = width;
    t->height_ = height;
    glGenRenderbuffers(1, &t->colour_);
    glBindRenderbuffer(GL_RENDERBUFFER, t->colour_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_SRGB8_ALPHA8, width, height);
    glGenRenderbuffers(1, &t->depth_);
    glBindRenderbuffer(GL_RENDERBUFFER, t->depth_);
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
    glBindRenderbuffer(GL_RENDERBUFFER, 0);
    glGenFramebuffers(1, &t->fbo_);
    glBindFramebuffer(GL_FRAMEBUFFER, t->fbo_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, t->colour_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, t->depth_);
    if (with_ids) {
        glGenRenderbuffers(1, &t->ids_);
        glBindRenderbuffer(GL_RENDERBUFFER, t->ids_);
        glRenderbufferStorage(GL_RENDERBUFFER, GL_R32UI, width, height);
        glBindRenderbuffer(GL_RENDERBUFFER, 0);
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_RENDERBUFFER, t->ids_);
    }
    t->setDrawBuffers();
    const GLenum complete = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (complete != GL_FRAMEBUFFER_COMPLETE) {
        *status = Status::Unsupported(fmt::format("offscreen target: {}x{} sRGB8_ALPHA8{} + depth24 framebuffer is "
                                           "incomplete (0x{:x})", width, height, with_ids ? " + R32UI" : "", complete));
        return nullptr;
    }
    *status = Status::Ok();
    return t;
}

OffscreenTarget::~OffscreenTarget() {
    if (fbo_ != 0) glDeleteFramebuffers(1, &fbo_);
    if (colour_ != 0) glDeleteRenderbuffers(1, &colour_);
    if (depth_ != 0) glDeleteRenderbuffers(1, &depth_);
    if (ids_ != 0) glDeleteRenderbuffers(1, &ids_);
}

void OffscreenTarget::setDrawBuffers() const {
    const GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(ids_ != 0 ? 2 : 1, buffers);
}

void OffscreenTarget::bind() const {
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
    glViewport(0, 0, width_, height_);
}

void OffscreenTarget::readPixels(std::vector<uint8_t>* rgba) const {
    const size_t row = static_cast<size_t>(width_) * 4;
    std::vector<uint8_t> bottom_up(row * height_);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, bottom_up.data());
    topDown(bottom_up, row, height_, rgba);
}

bool OffscreenTarget::readIds(std::vector<uint32_t>* ids) const {
    if (ids_ == 0) return false;
    const size_t row = static_cast<size_t>(width_);
    std::vector<uint32_t> bottom_up(row * height_);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, width_, height_, GL_RED_INTEGER, GL_UNSIGNED_INT, bottom_up.data());
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    topDown(bottom_up, row, height_, ids);
    return true;
}

void OffscreenTarget::readDepth(std::vector<float>* depth) const {
    const size_t row = static_cast<size_t>(width_);
    std::vector<float> bottom_up(row * height_);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, width_, height_, GL_DEPTH_COMPONENT, GL_FLOAT, bottom_up.data());
    topDown(bottom_up, row, height_, depth);
}

uint32_t OffscreenTarget::idAt(int x, int y) const {
    if (ids_ == 0 || x < 0 || y < 0 || x >= width_ || y >= height_) return kNoFeature;
    GLuint id = kNoFeature;
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(x, height_ - 1 - y, 1, 1, GL_RED_INTEGER, GL_UNSIGNED_INT, &id);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    return id;
}

void bindDefaultFramebuffer(int width, int height) {
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, width, height);
}

void OffscreenTarget::blitToDefault(int width, int height) const {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
    glBlitFramebuffer(0, 0, width_, height_, 0, 0, width, height, GL_COLOR_BUFFER_BIT, GL_LINEAR);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

// ---------------------------------------------------------------- GlRenderer

std::unique_ptr<GlRenderer> GlRenderer::create(const std::vector<MaterialInfo>& materials, Status* status) {
    return create(materials, RendererOptions{}, status);
}

std::unique_ptr<GlRenderer> GlRenderer::create(const std::vector<MaterialInfo>& materials,
                                               const RendererOptions& options, Status* status) {
    const GlInfo info = queryGlInfo();
    if (info.major * 10 + info.minor < 33) {
        *status = Status::Unsupported(fmt::format("GL renderer: OpenGL {} is below 3.3 ({})", info.version, info.renderer));
        return nullptr;
    }
    std::unique_ptr<GlRenderer> r(new GlRenderer());
    r->options_ = options;
    // sRGB S3TC keeps the sampler decoding to linear light like the CPU path;
    // plain S3TC alone would sample sRGB bytes as linear, so decode instead.
    r->cpu_decode_ = options.force_cpu_decode || !info.srgb_s3tc;
    r->anisotropic_ = info.anisotropic;
    r->anisotropy_ = std::clamp(options.max_anisotropy, 1.0F, info.max_anisotropy);

    std::string error;
    r->program_ = linkProgram(kVertexShader, kFragmentShader, &error);
    if (r->program_ == 0) {
        *status = Status::Unsupported(error);
        return nullptr;
    }
    const GLuint p = r->program_;
    r->u_view_projection_ = glGetUniformLocation(p, "u_view_projection");
    r->u_offset_ = glGetUniformLocation(p, "u_offset");
    r->u_uv_set_ = glGetUniformLocation(p, "u_uv_set");
    r->u_mode_ = glGetUniformLocation(p, "u_mode");
    r->u_opaque_ = glGetUniformLocation(p, "u_opaque");
    r->u_texture_ = glGetUniformLocation(p, "u_texture");
    r->u_materials_ = glGetUniformLocation(p, "u_materials");
    r->u_material_count_ = glGetUniformLocation(p, "u_material_count");
    r->u_pass_ = glGetUniformLocation(p, "u_pass");
    r->u_fade_ = glGetUniformLocation(p, "u_fade");
    r->u_fade_t_ = glGetUniformLocation(p, "u_fade_t");
    glUseProgram(p);
    glUniform1i(r->u_texture_, 0);
    glUniform1i(r->u_materials_, 1);
    glUniform1i(glGetUniformLocation(p, "u_styles"), 2);
    glUniform1i(glGetUniformLocation(p, "u_bases"), 3);
    glUniform1i(glGetUniformLocation(p, "u_tints"), 4);
    glUniform1i(glGetUniformLocation(p, "u_computed"), 5);
    glUniform1i(glGetUniformLocation(p, "u_ramp"), 6);
    r->u_computed_mode_ = glGetUniformLocation(p, "u_computed_mode");
    glUniform1i(r->u_material_count_, static_cast<GLint>(materials.size()));
    glUniform1f(glGetUniformLocation(p, "u_grey"), kNeutralGrey);
    glUseProgram(0);

    // Materials as a buffer texture: any count, one texelFetch per fragment.
    std::vector<float> table;
    table.reserve(4 * std::max<size_t>(materials.size(), 1));
    for (const MaterialInfo& m : materials) {
        table.insert(table.end(), {m.diffuse[0], m.diffuse[1], m.diffuse[2], 1.0F - m.transparency});
    }
    if (table.empty()) table = {kNeutralGrey, kNeutralGrey, kNeutralGrey, 1};  // a TBO needs a store
    r->material_count_ = static_cast<int>(materials.size());
    glGenBuffers(1, &r->material_buffer_);
    glBindBuffer(GL_TEXTURE_BUFFER, r->material_buffer_);
    glBufferData(GL_TEXTURE_BUFFER, static_cast<GLsizeiptr>(table.size() * sizeof(float)), table.data(),
                 GL_STATIC_DRAW);
    glGenTextures(1, &r->material_texture_);
    glBindTexture(GL_TEXTURE_BUFFER, r->material_texture_);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA32F, r->material_buffer_);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);

    // The computed textures' colour ramp: 256 x 1 sRGB, filtered in linear light.
    {
        std::vector<uint8_t> ramp;
        for (const RampColour& c : computedRamp()) ramp.insert(ramp.end(), {c[0], c[1], c[2], 255});
        glGenTextures(1, &r->ramp_texture_);
        glBindTexture(GL_TEXTURE_2D, r->ramp_texture_);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_SRGB8_ALPHA8, 256, 1, 0, GL_RGBA, GL_UNSIGNED_BYTE, ramp.data());
        setSampling(false, false, 1, 1);
        glBindTexture(GL_TEXTURE_2D, 0);
    }

    // The dummy: a 4x4 sRGB texture of one colour, one level.
    std::vector<uint8_t> dummy(4 * 4 * 4);
    for (size_t i = 0; i < dummy.size(); ++i) dummy[i] = kDummyColour[i % 4];
    glGenTextures(1, &r->dummy_.id);
    glBindTexture(GL_TEXTURE_2D, r->dummy_.id);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_SRGB8_ALPHA8, 4, 4, 0, GL_RGBA, GL_UNSIGNED_BYTE, dummy.data());
    setSampling(true, false, 1, 1);
    glBindTexture(GL_TEXTURE_2D, 0);
    r->dummy_.width = r->dummy_.height = 4;
    r->dummy_.channels = 4;
    r->dummy_.levels = 1;
    r->dummy_.wrap = true;
    r->dummy_.gpu_bytes = dummy.size();

    if (const GLenum e = glGetError(); e != GL_NO_ERROR) {
        *status = Status::Unsupported(fmt::format("GL renderer: setup failed with GL error 0x{:x}", e));
        return nullptr;
    }
    *status = Status::Ok();
    return r;
}

GlRenderer::~GlRenderer() {
    if (program_ != 0) glDeleteProgram(program_);
    if (material_texture_ != 0) glDeleteTextures(1, &material_texture_);
    for (uint32_t* t : {&style_texture_, &base_texture_, &tint_texture_, &ramp_texture_})
        if (*t != 0) glDeleteTextures(1, t);
    for (uint32_t* b : {&style_buffer_, &base_buffer_, &tint_buffer_})
        if (*b != 0) glDeleteBuffers(1, b);
    if (material_buffer_ != 0) glDeleteBuffers(1, &material_buffer_);
    release(&dummy_);
}

GpuMesh GlRenderer::upload(const MeshData& m, Status* status) {
    const auto start = std::chrono::steady_clock::now();
    GpuMesh g;
    if (Status s = checkMesh(m); !s.ok()) {
        setStatus(status, std::move(s));
        return g;
    }
    setStatus(status, Status::Ok());
    const size_t n = m.positions.size() / 3;
    if (n == 0 || m.indices.empty()) return g;

    g.vertex_count = static_cast<uint32_t>(n);
    g.index_count = static_cast<uint32_t>(m.indices.size());
    g.has_uv_atlas = !m.uv_atlas.empty();
    g.has_uv_original = !m.uv_original.empty();
    g.has_material_id = !m.material_id.empty();
    g.has_feature_id = !m.feature_id.empty();
    g.texture_ranges = m.texture_ranges;

    // One buffer, one block per attribute (no interleaving: absent attributes cost nothing).
    const size_t pos_bytes = m.positions.size() * sizeof(float);
    const size_t atlas_bytes = m.uv_atlas.size() * sizeof(float);
    const size_t orig_bytes = m.uv_original.size() * sizeof(float);
    const size_t mat_bytes = m.material_id.size() * sizeof(int32_t);
    const size_t feature_bytes = m.feature_id.size() * sizeof(uint32_t);
    const size_t atlas_at = pos_bytes, orig_at = atlas_at + atlas_bytes, mat_at = orig_at + orig_bytes;
    const size_t feature_at = mat_at + mat_bytes;
    const size_t vbo_bytes = feature_at + feature_bytes;

    glGenVertexArrays(1, &g.vao);
    glBindVertexArray(g.vao);
    glGenBuffers(1, &g.vbo);
    glBindBuffer(GL_ARRAY_BUFFER, g.vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(vbo_bytes), nullptr, GL_STATIC_DRAW);
    glBufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(pos_bytes), m.positions.data());
    glEnableVertexAttribArray(kPosition);
    glVertexAttribPointer(kPosition, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    auto at = [](size_t offset) { return reinterpret_cast<const void*>(offset); };
    if (g.has_uv_atlas) {
        glBufferSubData(GL_ARRAY_BUFFER, static_cast<GLintptr>(atlas_at), static_cast<GLsizeiptr>(atlas_bytes),
                        m.uv_atlas.data());
        glEnableVertexAttribArray(kUvAtlas);
        glVertexAttribPointer(kUvAtlas, 2, GL_FLOAT, GL_FALSE, 0, at(atlas_at));
    }
    if (g.has_uv_original) {
        glBufferSubData(GL_ARRAY_BUFFER, static_cast<GLintptr>(orig_at), static_cast<GLsizeiptr>(orig_bytes),
                        m.uv_original.data());
        glEnableVertexAttribArray(kUvOriginal);
        glVertexAttribPointer(kUvOriginal, 2, GL_FLOAT, GL_FALSE, 0, at(orig_at));
    }
    if (g.has_material_id) {
        glBufferSubData(GL_ARRAY_BUFFER, static_cast<GLintptr>(mat_at), static_cast<GLsizeiptr>(mat_bytes),
                        m.material_id.data());
        glEnableVertexAttribArray(kMaterial);
        glVertexAttribIPointer(kMaterial, 1, GL_INT, 0, at(mat_at));
    }
    if (g.has_feature_id) {
        glBufferSubData(GL_ARRAY_BUFFER, static_cast<GLintptr>(feature_at), static_cast<GLsizeiptr>(feature_bytes),
                        m.feature_id.data());
        glEnableVertexAttribArray(kFeature);
        glVertexAttribIPointer(kFeature, 1, GL_UNSIGNED_INT, 0, at(feature_at));
    }

    // 16-bit indices when they fit: half the index memory for most nodes.
    glGenBuffers(1, &g.ibo);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ibo);  // recorded in the VAO
    size_t ibo_bytes = 0;
    if (n <= 65536) {
        std::vector<uint16_t> shorts(m.indices.begin(), m.indices.end());
        ibo_bytes = shorts.size() * sizeof(uint16_t);
        glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(ibo_bytes), shorts.data(), GL_STATIC_DRAW);
        g.index_type = GL_UNSIGNED_SHORT;
    } else {
        ibo_bytes = m.indices.size() * sizeof(uint32_t);
        glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(ibo_bytes), m.indices.data(), GL_STATIC_DRAW);
        g.index_type = GL_UNSIGNED_INT;
    }
    glBindVertexArray(0);
    glBindBuffer(GL_ARRAY_BUFFER, 0);
    g.gpu_bytes = vbo_bytes + ibo_bytes;
    upload_bytes_ += g.gpu_bytes;
    upload_ms_ += elapsedMs(start);
    return g;
}

GpuTexture GlRenderer::upload(const CompressedTexture& t, bool wrap, Status* status) {
    const auto start = std::chrono::steady_clock::now();
    GpuTexture g;
    GLint max_size = 0;
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
    if (Status s = checkTexture(t, max_size); !s.ok()) {
        setStatus(status, std::move(s));
        return g;
    }
    g.width = t.width;
    g.height = t.height;
    g.channels = t.channels;
    g.levels = static_cast<int>(t.levels.size());
    g.wrap = wrap;
    // BC4 (RGTC1, a linear scalar) is core since GL 3.0: always sampled compressed.
    const bool cpu = cpu_decode_ && t.channels != 1;
    g.decoded_on_cpu = cpu;
    glGenTextures(1, &g.id);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, g.id);
    const GLenum format = t.channels == 1   ? GL_COMPRESSED_RED_RGTC1
                          : t.channels == 3 ? GL_COMPRESSED_SRGB_S3TC_DXT1_EXT
                                            : GL_COMPRESSED_SRGB_ALPHA_S3TC_DXT5_EXT;
    for (size_t i = 0; i < t.levels.size(); ++i) {
        const CompressedTexture::Level& level = t.levels[i];
        const uint8_t* blocks = t.data.data() + level.offset;
        if (!cpu) {
            glCompressedTexImage2D(GL_TEXTURE_2D, static_cast<GLint>(i), format, level.width, level.height, 0,
                                   static_cast<GLsizei>(level.bytes), blocks);
            g.gpu_bytes += level.bytes;
            continue;
        }
        const format::Image8 image =
            format::decodeBc(std::vector<uint8_t>(blocks, blocks + level.bytes), level.width, level.height, t.channels);
        std::vector<uint8_t> rgba(static_cast<size_t>(level.width) * level.height * 4, 255);
        const size_t texels = static_cast<size_t>(level.width) * level.height;
        for (size_t p = 0; p < texels; ++p)
            std::copy_n(image.pixels.data() + p * t.channels, t.channels, rgba.data() + p * 4);
        glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
        glTexImage2D(GL_TEXTURE_2D, static_cast<GLint>(i), GL_SRGB8_ALPHA8, level.width, level.height, 0, GL_RGBA,
                     GL_UNSIGNED_BYTE, rgba.data());
        g.gpu_bytes += rgba.size();
    }
    setSampling(wrap, anisotropic_, anisotropy_, g.levels);
    glBindTexture(GL_TEXTURE_2D, 0);
    if (const GLenum e = glGetError(); e != GL_NO_ERROR) {
        glDeleteTextures(1, &g.id);
        setStatus(status, Status::Unsupported(fmt::format("texture: {}x{} {} upload failed with GL error 0x{:x}", t.width,
                                                   t.height, format::bcFormatName(t.channels), e)));
        return GpuTexture{};
    }
    setStatus(status, Status::Ok());
    upload_bytes_ += g.gpu_bytes;
    upload_ms_ += elapsedMs(start);
    return g;
}

void GlRenderer::release(GpuMesh* mesh) {
    if (mesh->vao != 0) glDeleteVertexArrays(1, &mesh->vao);
    if (mesh->vbo != 0) glDeleteBuffers(1, &mesh->vbo);
    if (mesh->ibo != 0) glDeleteBuffers(1, &mesh->ibo);
    *mesh = GpuMesh{};
}

void GlRenderer::release(GpuTexture* texture) {
    if (texture->id != 0) glDeleteTextures(1, &texture->id);
    *texture = GpuTexture{};
}

// ---------------------------------------------------------------- frames

void GlRenderer::beginFrame(const Camera& camera, const std::array<float, 4>& clear_linear) {
    camera_ = camera;
    draws_.clear();
    nodes_.clear();
    glViewport(0, 0, camera.width_px, camera.height_px);
    glEnable(GL_FRAMEBUFFER_SRGB);  // the clear colour is linear too
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glDepthMask(GL_TRUE);
    glClearColor(clear_linear[0], clear_linear[1], clear_linear[2], clear_linear[3]);
    glClearDepth(1.0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    // glClear leaves an integer buffer undefined: the id buffer (an
    // OffscreenTarget's draw buffer 1) gets its own clear, to "no feature".
    GLint ids = GL_NONE;
    glGetIntegerv(GL_DRAW_BUFFER1, &ids);
    if (ids != GL_NONE) {
        const GLuint none[4] = {OffscreenTarget::kNoFeature, 0, 0, 0};
        glClearBufferuiv(GL_COLOR, 1, none);
    }
}

int GlRenderer::beginNode(const Vec3d& node_centre, int layer) {
    // The one place where world coordinates meet the camera: in double.
    const Vec3d offset = node_centre - camera_.position;
    NodeDraw node;
    node.offset = {static_cast<float>(offset.x), static_cast<float>(offset.y), static_cast<float>(offset.z)};
    node.distance = length(offset);
    node.layer = layer == 1 ? 1 : 0;
    node.fade = fade_mode_;
    node.fade_progress = fade_progress_;
    nodes_.push_back(node);
    return static_cast<int>(nodes_.size()) - 1;
}

void GlRenderer::queue(const GpuMesh& mesh, const GpuTexture* texture, int mode, bool uv_original, uint32_t first,
                       uint32_t count, const GpuTexture* computed) {
    if (count == 0) return;
    Draw d;
    d.mesh = &mesh;
    d.texture = texture != nullptr && texture->valid() ? texture : nullptr;
    d.mode = mode;
    if (d.texture == nullptr && mode == kModeTextured) d.mode = kModeColours;
    // A computed texture is sampled with uv_atlas: only where the mesh has them.
    if (d.mode == kModeTextured && computed != nullptr && computed->valid() && mesh.has_uv_atlas) d.computed = computed;
    d.uv_original = uv_original;
    d.first_index = first;
    d.index_count = count;
    d.node = static_cast<int>(nodes_.size()) - 1;
    draws_.push_back(d);
}

void GlRenderer::drawAtlas(const GpuMesh& mesh, const GpuTexture* atlas, const Vec3d& node_centre, int layer,
                           const GpuTexture* computed) {
    if (!mesh.valid()) return;
    beginNode(node_centre, layer);
    queue(mesh, atlas, kModeTextured, false, 0, mesh.index_count, computed);
}

void GlRenderer::drawOriginals(const GpuMesh& mesh, const std::function<const GpuTexture*(int32_t)>& original,
                               const GpuTexture* atlas_fallback, const Vec3d& node_centre, int layer,
                               const GpuTexture* computed) {
    if (!mesh.valid()) return;
    beginNode(node_centre, layer);
    if (mesh.texture_ranges.empty()) {
        queue(mesh, atlas_fallback, kModeTextured, false, 0, mesh.index_count, computed);
        return;
    }
    for (const MeshData::TextureRange& range : mesh.texture_ranges) {
        if (range.texture < 0) {
            queue(mesh, nullptr, kModeColours, false, range.first_index, range.index_count);
            continue;
        }
        const GpuTexture* texture = original ? original(range.texture) : nullptr;
        if (texture != nullptr && texture->valid() && mesh.has_uv_original) {
            queue(mesh, texture, kModeTextured, true, range.first_index, range.index_count, computed);
        } else {
            // Not resident (or never written): the node's atlas stands in.
            queue(mesh, atlas_fallback, kModeTextured, false, range.first_index, range.index_count, computed);
        }
    }
}

void GlRenderer::drawDummy(const GpuMesh& mesh, const Vec3d& node_centre, int layer) {
    if (!mesh.valid()) return;
    beginNode(node_centre, layer);
    queue(mesh, &dummy_, kModeDummy, false, 0, mesh.index_count);
}

namespace {
// A buffer texture over `bytes` (created on first use; at least one texel: a TBO needs a store).
void fillBufferTexture(uint32_t* buffer, uint32_t* texture, GLenum format, const void* data, size_t bytes,
                       size_t texel_bytes) {
    if (*buffer == 0) glGenBuffers(1, buffer);
    if (*texture == 0) glGenTextures(1, texture);
    std::vector<uint8_t> zero;
    if (bytes == 0) {
        zero.assign(texel_bytes, 0);
        data = zero.data();
        bytes = texel_bytes;
    }
    glBindBuffer(GL_TEXTURE_BUFFER, *buffer);
    glBufferData(GL_TEXTURE_BUFFER, static_cast<GLsizeiptr>(bytes), data, GL_DYNAMIC_DRAW);
    glBindTexture(GL_TEXTURE_BUFFER, *texture);
    glTexBuffer(GL_TEXTURE_BUFFER, format, *buffer);
    glBindTexture(GL_TEXTURE_BUFFER, 0);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
}
}  // namespace

void GlRenderer::setLens(const LensStyle& lens) {
    lens_ = lens;
    any_xray_ = std::find(lens.style.begin(), lens.style.end(), LensStyle::kXRay) != lens.style.end();
    fillBufferTexture(&style_buffer_, &style_texture_, GL_R8UI, lens.style.data(), lens.style.size(), 1);
    fillBufferTexture(&base_buffer_, &base_texture_, GL_R32F, lens.base_z.data(), lens.base_z.size() * sizeof(float), 4);
    fillBufferTexture(&tint_buffer_, &tint_texture_, GL_RGBA32F, lens.tint.data(), lens.tint.size() * sizeof(float) * 4, 16);
}

void GlRenderer::issue(const Draw& d, FrameStats* stats) {
    const GpuMesh& mesh = *d.mesh;
    const NodeDraw& node = nodes_[static_cast<size_t>(d.node)];
    glUniform3f(u_offset_, node.offset[0], node.offset[1], node.offset[2]);
    glUniform1i(u_fade_, node.fade);
    glUniform1f(u_fade_t_, node.fade_progress);
    glUniform1i(u_mode_, d.mode);
    glUniform1i(u_uv_set_, d.uv_original ? 1 : 0);
    const bool computed = d.computed != nullptr && computed_style_.mode != ComputedMode::Photo;
    glUniform1i(u_computed_mode_, computed ? static_cast<int>(computed_style_.mode) : 0);
    if (computed && d.computed->id != bound_computed_) {
        glActiveTexture(GL_TEXTURE5);
        glBindTexture(GL_TEXTURE_2D, d.computed->id);
        glActiveTexture(GL_TEXTURE0);
        bound_computed_ = d.computed->id;
        ++stats->texture_binds;
    }
    if (d.mode != kModeColours && d.texture != nullptr && d.texture->id != bound_texture_) {
        glBindTexture(GL_TEXTURE_2D, d.texture->id);
        bound_texture_ = d.texture->id;
        ++stats->texture_binds;
    }
    glBindVertexArray(mesh.vao);
    // Absent attributes read the context's current value (not VAO state): set it.
    if (!mesh.has_uv_atlas) glVertexAttrib2f(kUvAtlas, 0, 0);
    if (!mesh.has_uv_original) glVertexAttrib2f(kUvOriginal, 0, 0);
    if (!mesh.has_material_id) glVertexAttribI4i(kMaterial, -1, 0, 0, 0);
    if (!mesh.has_feature_id) glVertexAttribI4ui(kFeature, OffscreenTarget::kNoFeature, 0, 0, 0);
    const size_t index_size = mesh.index_type == GL_UNSIGNED_SHORT ? 2 : 4;
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(d.index_count), mesh.index_type,
                   reinterpret_cast<const void*>(static_cast<size_t>(d.first_index) * index_size));
    ++stats->draw_calls;
    stats->triangles += d.index_count / 3;
}

BlockMapLens GlRenderer::blockMapLens() const {
    return {lens_.style.empty() ? 0 : style_texture_, lens_.tint.empty() ? 0 : tint_texture_, &lens_};
}

FrameStats GlRenderer::endFrame() {
    FrameStats stats;
    stats.nodes = static_cast<uint32_t>(nodes_.size());
    stats.gpu_upload_ms = upload_ms_;
    stats.upload_bytes = upload_bytes_;
    upload_ms_ = 0;
    upload_bytes_ = 0;

    glUseProgram(program_);
    const std::array<float, 16> view_projection = multiply(projection(camera_), viewRotation(camera_));
    glUniformMatrix4fv(u_view_projection_, 1, GL_FALSE, view_projection.data());
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_BUFFER, material_texture_);
    // The lenses' tables (units 2-4) and parameters; every lens off without setLens.
    const bool styled = !lens_.style.empty(), tinted = !lens_.tint.empty();
    if (styled || tinted) {
        if (style_texture_ == 0) setLens(lens_);  // the empty tables, so the samplers are complete
        glActiveTexture(GL_TEXTURE2);
        glBindTexture(GL_TEXTURE_BUFFER, style_texture_);
        glActiveTexture(GL_TEXTURE3);
        glBindTexture(GL_TEXTURE_BUFFER, base_texture_);
        glActiveTexture(GL_TEXTURE4);
        glBindTexture(GL_TEXTURE_BUFFER, tint_texture_);
    }
    glActiveTexture(GL_TEXTURE6);
    glBindTexture(GL_TEXTURE_2D, ramp_texture_);
    glActiveTexture(GL_TEXTURE0);
    glUniform2f(glGetUniformLocation(program_, "u_computed_range"), computed_style_.b_min, computed_style_.b_max);
    glUniform4f(glGetUniformLocation(program_, "u_emphasis"), kEmphasisYellow[0], kEmphasisYellow[1], kEmphasisYellow[2],
                kEmphasisYellowWeight);
    bound_computed_ = 0;
    glUniform1i(glGetUniformLocation(program_, "u_styled"), styled ? 1 : 0);
    glUniform1i(glGetUniformLocation(program_, "u_tinted"), tinted ? 1 : 0);
    glUniform1f(glGetUniformLocation(program_, "u_flatten"), lens_.flatten);
    glUniform1f(glGetUniformLocation(program_, "u_camera_z"), static_cast<float>(camera_.position.z));
    glUniform1f(glGetUniformLocation(program_, "u_xray_falloff"), lens_.xray_falloff);
    glUniform1i(glGetUniformLocation(program_, "u_lens"), lens_.lens);
    {
        // The lens centre relative to the camera, in double until here.
        const Vec3d c = lens_.lens_centre - camera_.position;
        glUniform3f(glGetUniformLocation(program_, "u_lens_centre"), static_cast<float>(c.x), static_cast<float>(c.y),
                    static_cast<float>(c.z));
        glUniform1f(glGetUniformLocation(program_, "u_lens_radius"), static_cast<float>(lens_.lens_radius_m));
        glUniform2f(glGetUniformLocation(program_, "u_context"), lens_.context_saturation, lens_.context_brightness);
    }
    bound_texture_ = 0;  // uploads and other code bind textures too: issue the first bind
    glEnable(GL_FRAMEBUFFER_SRGB);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDisable(GL_CULL_FACE);  // city data has inconsistent winding

    // Opaque first, in call order, writing depth.
    glDisable(GL_BLEND);
    glDepthMask(GL_TRUE);
    glUniform1i(u_opaque_, 1);
    glUniform1i(u_pass_, 0);
    for (const Draw& d : draws_) {
        if (nodes_[static_cast<size_t>(d.node)].layer == 0) issue(d, &stats);
    }
    // X-ray faces: every draw once more, only x-ray features' fragments, blended
    // over what is behind them, without depth or id writes (picking sees through).
    if (any_xray_) {
        glEnable(GL_BLEND);
        glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
        glDepthMask(GL_FALSE);
        glColorMaski(1, GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
        glUniform1i(u_pass_, 2);
        for (const Draw& d : draws_) issue(d, &stats);
        glColorMaski(1, GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
        glDepthMask(GL_TRUE);
        glDisable(GL_BLEND);
        glUniform1i(u_pass_, 0);
    }

    // Then the alpha layer, far nodes first (per node: triangles within a node
    // keep their order), tested against the opaque depth but not writing it.
    std::vector<const Draw*> alpha;
    for (const Draw& d : draws_) {
        if (nodes_[static_cast<size_t>(d.node)].layer == 1) alpha.push_back(&d);
    }
    std::stable_sort(alpha.begin(), alpha.end(), [&](const Draw* a, const Draw* b) {
        return nodes_[static_cast<size_t>(a->node)].distance > nodes_[static_cast<size_t>(b->node)].distance;
    });
    if (!alpha.empty()) {
        glEnable(GL_BLEND);
        glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
        glDepthMask(GL_FALSE);
        glUniform1i(u_opaque_, 0);
        glUniform1i(u_pass_, 1);
        for (const Draw* d : alpha) issue(*d, &stats);
    }

    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    glDisable(GL_FRAMEBUFFER_SRGB);
    glBindVertexArray(0);
    glUseProgram(0);
    draws_.clear();
    nodes_.clear();
    return stats;
}

Status GlRenderer::applyEdges(const OffscreenTarget& target, const EdgeStyle& style) {
    if (!style.enabled) return Status::Ok();
    if (!edges_) {
        Status st;
        edges_ = EdgePass::create(&st);
        if (!edges_) return st;
    }
    return edges_->apply(target, camera_, style);
}

void GlRenderer::finish() { glFinish(); }

}  // namespace cityatlas::render
