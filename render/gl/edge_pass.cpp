// SPDX-License-Identifier: GPL-3.0-or-later
// Edge enhancement over a finished frame (render/gl/edge_pass.h).
#include "render/gl/edge_pass.h"

#include <string>

#include <epoxy/gl.h>
#include <fmt/format.h>

#include "render/gl/gl_program.h"
#include "render/gl/gl_renderer.h"

namespace cityatlas::render {
namespace {

// One triangle over the whole viewport, from gl_VertexID alone.
constexpr const char* kVertexShader = R"(#version 330 core
void main() {
    gl_Position = vec4(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0, 0.0, 1.0);
}
)";

// Writes 1 - strength where the pixel is an edge (blended as a factor on the
// colour), discards elsewhere: the rule of edge_pass.h.
constexpr const char* kFragmentShader = R"(#version 330 core
uniform usampler2D u_ids;
uniform sampler2D u_depth;
uniform vec2 u_near_far;
uniform float u_strength;
uniform float u_crease;
out vec4 o_factor;
const uint kNone = 0xFFFFFFFFu;
// 1 / eye depth from the window depth: affine in screen space over a plane.
float invDepth(ivec2 p) {
    float n = u_near_far.x, f = u_near_far.y;
    float z = 2.0 * texelFetch(u_depth, p, 0).r - 1.0;
    return (f + n - z * (f - n)) / (2.0 * n * f);
}
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 size = textureSize(u_ids, 0);
    if (p.x < 1 || p.y < 1 || p.x >= size.x - 1 || p.y >= size.y - 1) discard;
    uint id = texelFetch(u_ids, p, 0).r;
    if (id == kNone) discard;
    bool edge = texelFetch(u_ids, p + ivec2(1, 0), 0).r != id || texelFetch(u_ids, p - ivec2(1, 0), 0).r != id ||
                texelFetch(u_ids, p + ivec2(0, 1), 0).r != id || texelFetch(u_ids, p - ivec2(0, 1), 0).r != id;
    float c = invDepth(p);
    float h = invDepth(p + ivec2(1, 0)) + invDepth(p - ivec2(1, 0)) - 2.0 * c;
    float v = invDepth(p + ivec2(0, 1)) + invDepth(p - ivec2(0, 1)) - 2.0 * c;
    if (!edge && abs(h) <= u_crease * c && abs(v) <= u_crease * c) discard;
    o_factor = vec4(vec3(1.0 - u_strength), 1.0);
}
)";

}  // namespace

std::unique_ptr<EdgePass> EdgePass::create(Status* status) {
    std::unique_ptr<EdgePass> e(new EdgePass());
    std::string error;
    e->program_ = linkProgram(kVertexShader, kFragmentShader, &error);
    if (e->program_ == 0) {
        *status = Status::Unsupported(fmt::format("edge pass: {}", error));
        return nullptr;
    }
    glUseProgram(e->program_);
    glUniform1i(glGetUniformLocation(e->program_, "u_ids"), 0);
    glUniform1i(glGetUniformLocation(e->program_, "u_depth"), 1);
    glUseProgram(0);
    glGenVertexArrays(1, &e->vao_);  // core profile: a draw needs a vertex array, even without attributes
    glGenFramebuffers(1, &e->fbo_);
    *status = Status::Ok();
    return e;
}

EdgePass::~EdgePass() {
    if (program_ != 0) glDeleteProgram(program_);
    if (vao_ != 0) glDeleteVertexArrays(1, &vao_);
    if (fbo_ != 0) glDeleteFramebuffers(1, &fbo_);
    if (ids_ != 0) glDeleteTextures(1, &ids_);
    if (depth_ != 0) glDeleteTextures(1, &depth_);
}

Status EdgePass::apply(const OffscreenTarget& target, const Camera& camera, const EdgeStyle& style) {
    if (!target.hasIds()) return Status::Unsupported("edge pass: the target has no id buffer");
    const int w = target.width(), h = target.height();
    // The copies, sized to the target: R32UI ids and 24-bit depth, sampled texel by texel.
    if (w != width_ || h != height_) {
        for (uint32_t* t : {&ids_, &depth_})
            if (*t != 0) glDeleteTextures(1, t), *t = 0;
        glGenTextures(1, &ids_);
        glBindTexture(GL_TEXTURE_2D, ids_);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_R32UI, w, h, 0, GL_RED_INTEGER, GL_UNSIGNED_INT, nullptr);
        glGenTextures(1, &depth_);
        glBindTexture(GL_TEXTURE_2D, depth_);
        glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, w, h, 0, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, nullptr);
        for (const uint32_t t : {ids_, depth_}) {
            glBindTexture(GL_TEXTURE_2D, t);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
        }
        glBindTexture(GL_TEXTURE_2D, 0);
        glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, ids_, 0);
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth_, 0);
        const GLenum complete = glCheckFramebufferStatus(GL_FRAMEBUFFER);
        if (complete != GL_FRAMEBUFFER_COMPLETE) {
            width_ = height_ = 0;
            return Status::Unsupported(fmt::format("edge pass: R32UI + depth24 texture framebuffer is incomplete (0x{:x})", complete));
        }
        width_ = w, height_ = h;
    }
    // Copy the target's ids (attachment 1) and depth: a renderbuffer being
    // drawn into cannot be sampled.
    glBindFramebuffer(GL_READ_FRAMEBUFFER, target.framebuffer());
    glReadBuffer(GL_COLOR_ATTACHMENT1);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, fbo_);
    const GLenum copy_to = GL_COLOR_ATTACHMENT0;
    glDrawBuffers(1, &copy_to);
    glBlitFramebuffer(0, 0, w, h, 0, 0, w, h, GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT, GL_NEAREST);
    glReadBuffer(GL_COLOR_ATTACHMENT0);

    // The factor onto the colour only, in linear light.
    target.bind();
    const GLenum colour_only = GL_COLOR_ATTACHMENT0;
    glDrawBuffers(1, &colour_only);
    glDisable(GL_DEPTH_TEST);
    glDepthMask(GL_FALSE);
    glEnable(GL_FRAMEBUFFER_SRGB);
    glEnable(GL_BLEND);
    glBlendFunc(GL_ZERO, GL_SRC_COLOR);
    glUseProgram(program_);
    glUniform2f(glGetUniformLocation(program_, "u_near_far"), static_cast<float>(camera.near_m), static_cast<float>(camera.far_m));
    glUniform1f(glGetUniformLocation(program_, "u_strength"), style.strength);
    glUniform1f(glGetUniformLocation(program_, "u_crease"), style.crease);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, ids_);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, depth_);
    glBindVertexArray(vao_);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    // Back to what the renderer expects: both draw buffers, depth on, no blending.
    glBindVertexArray(0);
    glBindTexture(GL_TEXTURE_2D, 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, 0);
    glUseProgram(0);
    glDisable(GL_BLEND);
    glDisable(GL_FRAMEBUFFER_SRGB);
    glDepthMask(GL_TRUE);
    glEnable(GL_DEPTH_TEST);
    const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, both);
    return Status::Ok();
}

}  // namespace cityatlas::render
