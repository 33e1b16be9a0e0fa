// SPDX-License-Identifier: GPL-3.0-or-later
// BlockMapPass: a BlockMap's box rasterised, its cells ray-cast per fragment
// (blockmap_pass.h); the walk is render/core/blockmap_ray.cpp's, step for step.
#include "render/gl/blockmap_pass.h"

#include <epoxy/gl.h>

#include <array>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "render/gl/gl_program.h"
#include "render/gl/screen_door.h"

namespace cityatlas::render {
namespace {

constexpr const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_grid;  // a box corner, grid units
uniform mat4 u_view_projection;       // projection * viewRotation: no translation
uniform vec3 u_box_offset;            // grid origin - camera, metres (double on the CPU)
uniform float u_cell;                 // cell side, metres
out vec3 v_grid;
void main() {
    v_grid = a_grid;
    gl_Position = u_view_projection * vec4(u_box_offset + a_grid * u_cell, 1.0);
}
)";

// Faces as render/core/blockmap_ray.h: 0 +x, 1 -x, 2 +y, 3 -y (the side of
// the hit cell), 4 roof, 5 underside.
constexpr const char* kFragmentShader = R"(#version 330 core
in vec3 v_grid;
uniform mat4 u_view_projection;
uniform vec3 u_box_offset;
uniform float u_cell;
uniform vec3 u_camera;             // camera, grid units
uniform ivec2 u_n;                 // nx, ny
uniform float u_height;            // the height range, grid units
uniform usampler2D u_cells;        // top, base, local feature, first column
uniform usampler2D u_dist;         // Chebyshev distance to a building, <= 255
uniform sampler2D u_roof;          // sRGB
uniform sampler2D u_walls;         // sRGB
uniform usamplerBuffer u_columns;  // x, y, rows, base
uniform usamplerBuffer u_features; // local -> feature id
uniform bool u_coloured;           // roof and walls given (else grey)
uniform bool u_cell_ids;           // test hook: ids = cell * 8 + face
uniform bool u_styled;             // lenses (blockmap_pass.h BlockMapLens): per-feature styles
uniform usamplerBuffer u_styles;
uniform float u_flatten;
uniform bool u_tinted;             // per-feature tints: linear rgb and weight
uniform samplerBuffer u_tints;
uniform int u_lens;                // analytic lens: 0 none, 1 sphere, 2 vertical cylinder
uniform vec3 u_lens_centre;        // relative to the camera, metres
uniform float u_lens_radius;
uniform vec2 u_context;            // outside the lens: saturation, brightness
layout(location = 0) out vec4 o_colour;
layout(location = 1) out uint o_feature;
)" CITYATLAS_SCREEN_DOOR_GLSL R"(
const uint kNone = 0xFFFFFFFFu;
float heightOf(uint q) { return float(q) / 65535.0 * u_height; }
bool outside(ivec2 c) { return any(lessThan(c, ivec2(0))) || any(greaterThanEqual(c, u_n)); }
// format/blockmap.h's rule: the neighbour covers the side (as high, as low a base).
bool covered(ivec2 n, uvec4 cell) {
    if (outside(n)) return false;
    uvec4 m = texelFetch(u_cells, n, 0);
    return m.b != kNone && m.r >= cell.r && m.g <= cell.g;
}

void main() {
    if (screenDoorDiscards()) discard;  // the cross-fade, before any ray is cast
    vec3 o = u_camera;
    vec3 d = v_grid - u_camera;
    vec3 inv = 1.0 / d;
    vec3 ta = -o * inv, tb = (vec3(vec2(u_n), u_height) - o) * inv;
    vec3 tnear = min(ta, tb), tfar = max(ta, tb);
    float t_exit = min(min(tfar.x, tfar.y), tfar.z);
    float t = max(max(max(tnear.x, tnear.y), tnear.z), 0.0);
    int face = 4;
    if (tnear.z >= max(tnear.x, tnear.y)) face = d.z < 0.0 ? 4 : 5;
    else if (tnear.x >= tnear.y) face = d.x > 0.0 ? 1 : 0;
    else face = d.y > 0.0 ? 3 : 2;
    ivec2 step = ivec2(d.x > 0.0 ? 1 : -1, d.y > 0.0 ? 1 : -1);
    vec2 tdelta = abs(inv.xy);
    ivec2 c;
    vec2 tmax;
    // enter(t): the cell at t, the entered side deciding on a boundary
    #define ENTER() { vec2 p = o.xy + d.xy * t; \
        c = clamp(ivec2(floor(p)), ivec2(0), u_n - 1); \
        if (face == 1) c.x = clamp(int(round(p.x)), 0, u_n.x - 1); \
        if (face == 0) c.x = clamp(int(round(p.x)) - 1, 0, u_n.x - 1); \
        if (face == 3) c.y = clamp(int(round(p.y)), 0, u_n.y - 1); \
        if (face == 2) c.y = clamp(int(round(p.y)) - 1, 0, u_n.y - 1); \
        tmax = (vec2(c + max(step, ivec2(0))) - o.xy) * inv.xy; }
    ENTER();
    int max_steps = u_n.x + u_n.y + 8;
    for (int i = 0; i < max_steps; ++i) {
        uint dist = texelFetch(u_dist, c, 0).r;
        if (dist >= 2u) {
            vec2 lo = vec2(c) - float(dist - 1u), hi = vec2(c) + float(dist);
            vec2 tx = (mix(lo, hi, greaterThan(d.xy, vec2(0.0))) - o.xy) * inv.xy;
            float tl = min(tx.x, tx.y);
            if (tl >= t_exit) discard;
            face = tx.x < tx.y ? (d.x > 0.0 ? 1 : 0) : (d.y > 0.0 ? 3 : 2);
            t = tl;
            vec2 p = o.xy + d.xy * t;
            if ((face == 1 && int(round(p.x)) >= u_n.x) || (face == 0 && int(round(p.x)) <= 0) ||
                (face == 3 && int(round(p.y)) >= u_n.y) || (face == 2 && int(round(p.y)) <= 0)) discard;
            ENTER();
            continue;
        }
        float t_out = min(min(tmax.x, tmax.y), t_exit);
        uvec4 cell = texelFetch(u_cells, c, 0);
        uint fid = cell.b != kNone ? texelFetch(u_features, int(cell.b)).r : kNone;
        uint style = u_styled && cell.b != kNone && fid < uint(textureSize(u_styles)) ? texelFetch(u_styles, int(fid)).r : 0u;
        if (cell.b != kNone && style != 1u && style != 2u) {  // discarded and x-ray buildings: the ray goes on
            float h = heightOf(cell.r), b = heightOf(cell.g);
            if (style == 3u) h = b + (h - b) * u_flatten;
            float z_in = o.z + d.z * t, z_out = o.z + d.z * t_out;
            float hit_t = -1.0;
            int hit_face = face;
            // sideSkirt (render/core/blockmap_ray.h): below the base by what the ray descends over half a cell
            float skirt = d.z < 0.0 && face < 4 && length(d.xy) > 0.0 ? 0.5 * -d.z / length(d.xy) : 0.0;
            if (z_in >= max(b - skirt, 0.0) && z_in <= h) hit_t = t;  // never below the box (the proxy drawn)
            else if (z_in > h && z_out <= h) { hit_t = t + (h - z_in) / d.z; hit_face = 4; }
            else if (z_in < b && z_out >= b) { hit_t = t + (b - z_in) / d.z; hit_face = 5; }
            if (hit_t >= 0.0) {
                vec3 hit = o + d * hit_t;
                vec3 colour = vec3(0.7);
                if (hit_face == 5) colour = vec3(0.1);
                else if (u_coloured && hit_face == 4) colour = texelFetch(u_roof, c, 0).rgb;
                else if (u_coloured) {
                    // this side's column: the cell's first plus its exposed sides before it (+x, -x, +y, -y)
                    const ivec2 nb[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
                    int rank = 0;
                    for (int k = 0; k < hit_face; ++k) rank += covered(c + nb[k], cell) ? 0 : 1;
                    uvec4 col = texelFetch(u_columns, int(cell.a) + rank);
                    float zb = heightOf(col.a);
                    int row = clamp(int((hit.z - zb) / max(h - zb, 1e-6) * float(col.b)), 0, int(col.b) - 1);
                    colour = texelFetch(u_walls, ivec2(col.r, int(col.g) + row), 0).rgb;
                }
                if (u_tinted && fid < uint(textureSize(u_tints))) {
                    vec4 tint = texelFetch(u_tints, int(fid));
                    colour = mix(colour, tint.rgb, tint.a);
                }
                vec3 rel = u_box_offset + hit * u_cell;  // relative to the camera, metres
                if (u_lens != 0) {
                    vec3 ld = rel - u_lens_centre;
                    float r = u_lens == 1 ? length(ld) : length(ld.xy);
                    if (!(r < u_lens_radius)) {
                        float grey = dot(colour, vec3(0.2126, 0.7152, 0.0722));
                        colour = mix(vec3(grey), colour, u_context.x) * u_context.y;
                    }
                }
                vec4 clip = u_view_projection * vec4(rel, 1.0);
                gl_FragDepth = 0.5 * clip.z / clip.w + 0.5;
                o_colour = vec4(colour, 1.0);
                o_feature = u_cell_ids ? uint(c.y * u_n.x + c.x) * 8u + uint(hit_face) : fid;
                return;
            }
        }
        if (t_out >= t_exit) discard;
        t = t_out;
        if (tmax.x < tmax.y) { c.x += step.x; tmax.x += tdelta.x; face = step.x > 0 ? 1 : 0; }
        else { c.y += step.y; tmax.y += tdelta.y; face = step.y > 0 ? 3 : 2; }
        if (outside(c)) discard;
    }
    discard;
}
)";

uint32_t makeTexture(GLenum internal, GLenum format, GLenum type, int w, int h, const void* data) {
    GLuint t = 0;
    glGenTextures(1, &t);
    glBindTexture(GL_TEXTURE_2D, t);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(internal), w, h, 0, format, type, data);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
    return t;
}

template <typename T>
void makeBufferTexture(GLenum internal, const std::vector<T>& data, uint32_t* buffer, uint32_t* texture) {
    glGenBuffers(1, buffer);
    glBindBuffer(GL_TEXTURE_BUFFER, *buffer);
    // An empty table still gets one element (a zero-sized buffer store is an error on some drivers).
    const std::vector<T> one(4, T{});
    const auto& src = data.empty() ? one : data;
    glBufferData(GL_TEXTURE_BUFFER, static_cast<GLsizeiptr>(src.size() * sizeof(T)), src.data(), GL_STATIC_DRAW);
    glGenTextures(1, texture);
    glBindTexture(GL_TEXTURE_BUFFER, *texture);
    glTexBuffer(GL_TEXTURE_BUFFER, internal, *buffer);
    glBindBuffer(GL_TEXTURE_BUFFER, 0);
}

}  // namespace

std::unique_ptr<BlockMapPass> BlockMapPass::create(Status* status) {
    std::string error;
    const GLuint program = linkProgram(kVertexShader, kFragmentShader, &error);
    if (!program) {
        *status = Status::Fail(StatusCode::kUnsupported, "BlockMap pass: " + error);
        return nullptr;
    }
    std::unique_ptr<BlockMapPass> pass(new BlockMapPass);
    pass->program_ = program;
    // The box's 8 corners in grid units, written per draw (each BlockMap has its own extent).
    glGenVertexArrays(1, &pass->vao_);
    glBindVertexArray(pass->vao_);
    glGenBuffers(1, &pass->vbo_);
    glBindBuffer(GL_ARRAY_BUFFER, pass->vbo_);
    glBufferData(GL_ARRAY_BUFFER, 8 * 3 * sizeof(float), nullptr, GL_DYNAMIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    // Counter-clockwise seen from outside, so back faces can be culled.
    const uint16_t indices[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                                  2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    glGenBuffers(1, &pass->ibo_);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, pass->ibo_);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, sizeof(indices), indices, GL_STATIC_DRAW);
    glBindVertexArray(0);
    return pass;
}

BlockMapPass::~BlockMapPass() {
    glDeleteProgram(program_);
    glDeleteBuffers(1, &vbo_);
    glDeleteBuffers(1, &ibo_);
    glDeleteVertexArrays(1, &vao_);
}

GpuBlockMap BlockMapPass::upload(const format::BlockMap& bm, std::span<const uint8_t> roof, std::span<const uint8_t> walls,
                                 Status* status) {
    const size_t cells = static_cast<size_t>(bm.nx) * static_cast<size_t>(bm.ny);
    const size_t wall_texels = static_cast<size_t>(bm.wall_width) * static_cast<size_t>(bm.wall_height);
    if (bm.nx <= 0 || bm.ny <= 0 || bm.cells.size() != cells || bm.dist.size() != cells ||
        (!roof.empty() && roof.size() != cells * 3) || (!walls.empty() && walls.size() != wall_texels * 3) ||
        roof.empty() != walls.empty()) {
        *status = Status::Fail(StatusCode::kInvalidInput,
                               fmt::format("BlockMap upload: planes do not match the {} x {} grid", bm.nx, bm.ny));
        return {};
    }
    GpuBlockMap g;
    g.nx = bm.nx, g.ny = bm.ny, g.cell_m = bm.cell_m, g.origin = bm.origin, g.z_hi = bm.z_hi;
    std::vector<uint32_t> packed;
    packed.reserve(cells * 4);
    for (const format::BlockMapCell& c : bm.cells) packed.insert(packed.end(), {c.top, c.base, c.feature, c.first_column});
    g.cells = makeTexture(GL_RGBA32UI, GL_RGBA_INTEGER, GL_UNSIGNED_INT, bm.nx, bm.ny, packed.data());
    g.dist = makeTexture(GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, bm.nx, bm.ny, bm.dist.data());
    if (!roof.empty()) {
        g.roof = makeTexture(GL_SRGB8, GL_RGB, GL_UNSIGNED_BYTE, bm.nx, bm.ny, roof.data());
        g.walls = makeTexture(GL_SRGB8, GL_RGB, GL_UNSIGNED_BYTE, bm.wall_width, std::max(1, bm.wall_height), walls.data());
    }
    std::vector<uint16_t> columns;
    for (const format::BlockMapColumn& c : bm.columns) columns.insert(columns.end(), {c.x, c.y, c.rows, c.base});
    makeBufferTexture(GL_RGBA16UI, columns, &g.columns_buffer, &g.columns);
    makeBufferTexture(GL_R32UI, bm.features, &g.features_buffer, &g.features);
    g.gpu_bytes = bm.gpuBytes(!roof.empty());
    return g;
}

void BlockMapPass::release(GpuBlockMap* g) {
    const GLuint textures[6] = {g->cells, g->dist, g->roof, g->walls, g->columns, g->features};
    glDeleteTextures(6, textures);
    const GLuint buffers[2] = {g->columns_buffer, g->features_buffer};
    glDeleteBuffers(2, buffers);
    *g = GpuBlockMap{};
}

void BlockMapPass::draw(const GpuBlockMap& g, const Camera& camera, const BlockMapLens* lens, int fade, float fade_t) {
    if (!g.valid()) return;
    const double s = g.cell_m;
    const auto bx = static_cast<float>(g.nx), by = static_cast<float>(g.ny);
    const auto bz = static_cast<float>((g.z_hi - g.origin.z) / s);
    const float corners[8][3] = {{0, 0, 0}, {bx, 0, 0}, {0, by, 0}, {bx, by, 0}, {0, 0, bz}, {bx, 0, bz}, {0, by, bz}, {bx, by, bz}};
    glBindVertexArray(vao_);
    glBindBuffer(GL_ARRAY_BUFFER, vbo_);
    glBufferSubData(GL_ARRAY_BUFFER, 0, sizeof(corners), corners);
    glUseProgram(program_);
    const std::array<float, 16> vp = [&] {
        const auto p = projection(camera), v = viewRotation(camera);
        std::array<float, 16> m{};
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r)
                for (int k = 0; k < 4; ++k) m[c * 4 + r] += p[k * 4 + r] * v[c * 4 + k];
        return m;
    }();
    const Vec3d offset = g.origin - camera.position;  // double, then rounded once
    const Vec3d cam = (1.0 / s) * (camera.position - g.origin);
    auto loc = [&](const char* name) { return glGetUniformLocation(program_, name); };
    glUniformMatrix4fv(loc("u_view_projection"), 1, GL_FALSE, vp.data());
    glUniform3f(loc("u_box_offset"), static_cast<float>(offset.x), static_cast<float>(offset.y), static_cast<float>(offset.z));
    glUniform1f(loc("u_cell"), static_cast<float>(s));
    glUniform3f(loc("u_camera"), static_cast<float>(cam.x), static_cast<float>(cam.y), static_cast<float>(cam.z));
    glUniform2i(loc("u_n"), g.nx, g.ny);
    glUniform1f(loc("u_height"), bz);
    glUniform1i(loc("u_coloured"), g.roof != 0);
    glUniform1i(loc("u_cell_ids"), cell_ids_);
    glUniform1i(loc("u_fade"), fade);
    glUniform1f(loc("u_fade_t"), fade_t);
    const std::pair<const char*, std::pair<GLenum, uint32_t>> units[6] = {
        {"u_cells", {GL_TEXTURE_2D, g.cells}},       {"u_dist", {GL_TEXTURE_2D, g.dist}},
        {"u_roof", {GL_TEXTURE_2D, g.roof}},         {"u_walls", {GL_TEXTURE_2D, g.walls}},
        {"u_columns", {GL_TEXTURE_BUFFER, g.columns}}, {"u_features", {GL_TEXTURE_BUFFER, g.features}}};
    for (int u = 0; u < 6; ++u) {
        glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(u));
        glBindTexture(units[u].second.first, units[u].second.second);
        glUniform1i(loc(units[u].first), u);
    }
    // The lenses' tables on units 6 and 7 (samplers of a type share no unit).
    const bool styled = lens && lens->styles != 0, tinted = lens && lens->tints != 0;
    glActiveTexture(GL_TEXTURE6);
    glBindTexture(GL_TEXTURE_BUFFER, styled ? lens->styles : 0);
    glActiveTexture(GL_TEXTURE7);
    glBindTexture(GL_TEXTURE_BUFFER, tinted ? lens->tints : 0);
    glUniform1i(loc("u_styles"), 6);
    glUniform1i(loc("u_tints"), 7);
    glUniform1i(loc("u_styled"), styled);
    glUniform1i(loc("u_tinted"), tinted);
    const LensStyle* style = lens ? lens->style : nullptr;
    glUniform1f(loc("u_flatten"), style ? style->flatten : 1.0F);
    glUniform1i(loc("u_lens"), style ? style->lens : 0);
    if (style) {
        const Vec3d c = style->lens_centre - camera.position;  // double, then rounded once
        glUniform3f(loc("u_lens_centre"), static_cast<float>(c.x), static_cast<float>(c.y), static_cast<float>(c.z));
        glUniform1f(loc("u_lens_radius"), static_cast<float>(style->lens_radius_m));
        glUniform2f(loc("u_context"), style->context_saturation, style->context_brightness);
    }
    glEnable(GL_DEPTH_TEST);
    glDepthMask(GL_TRUE);
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glFrontFace(GL_CCW);
    glEnable(GL_FRAMEBUFFER_SRGB);
    glDrawElements(GL_TRIANGLES, 36, GL_UNSIGNED_SHORT, nullptr);
    glDisable(GL_CULL_FACE);
    glDisable(GL_FRAMEBUFFER_SRGB);
    glActiveTexture(GL_TEXTURE0);
    glBindVertexArray(0);
}

}  // namespace cityatlas::render
