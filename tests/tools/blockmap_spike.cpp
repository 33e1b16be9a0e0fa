// SPDX-License-Identifier: GPL-3.0-or-later
// Issue 20's spike: a root BlockMap (papers/002, SEED-FEATURES.md §1) of a
// synthetic town, against the root's geometry and atlases in a built folder:
// bytes, build seconds and frame time. Not a test and not the feature: the
// planes are atlas/blockmap.h's (cells with top, base, building and first
// column; distance plane; one column per exposed side, shelf-packed into a
// 1024-wide wall image; column table; feature ids), but colours are a
// palette per building instead of the facade textures sampled (the rays
// that would sample them are cast and timed; the texture reads are not), and
// columns are packed in cell order, not unfolded per building. The GL part
// ray-casts the BlockMap with the DDA of §1.2 (space leaping on the
// distance plane, gl_FragDepth) on the current EGL device.
//
// Usage: blockmap_spike BUILDINGS TEXTURE_PX TILE_FOLDER OUT_DIR [WxH] [FRAMES]
//   The town is synth --buildings BUILDINGS --texture-size TEXTURE_PX --lod 2
//   --seed 1 (benchmarks/build_scale.sh's), TILE_FOLDER its build. Writes
//   OUT_DIR/spike.json, OUT_DIR/cameras.json (the same cameras as a camera
//   path for `cityatlas render`) and OUT_DIR/blockmap-<camera>.png.
#include <tbb/parallel_for.h>

#include <zstd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <epoxy/gl.h>
#include <nlohmann/json.hpp>
#include <OpenImageIO/imageio.h>

#include "atlas/blockmap.h"
#include "atlas/raycast.h"
#include "ingest/synth/town.h"
#include "render/gl/gl_context.h"
#include "render/gl/gl_program.h"
#include "render/gl/gl_renderer.h"

using namespace cityatlas;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The planes (atlas/blockmap.h) and the spike's colour planes.
struct SpikeBlockMap {
    format::BlockMap planes;
    std::vector<uint8_t> roof;   // RGB8, nx x ny
    std::vector<uint8_t> walls;  // RGB8, wall_width x wall_height
};

std::array<uint8_t, 3> palette(uint32_t feature, double shade) {
    uint32_t h = feature * 2654435761u;
    auto c = [&](int k) { return static_cast<uint8_t>(std::clamp((90 + ((h >> (8 * k)) & 0x7F)) * shade, 0.0, 255.0)); };
    return {c(0), c(1), c(2)};
}

size_t zstdBytes(const void* data, size_t n) {
    std::vector<char> out(ZSTD_compressBound(n));
    const size_t r = ZSTD_compress(out.data(), out.size(), data, n, 19);
    return ZSTD_isError(r) ? n : r;
}

// The root BlockMap of the whole scene (the root holds every building) at cell side s.
json buildSpike(const Scene& scene, double s, SpikeBlockMap* out) {
    json timing;
    auto t0 = Clock::now();
    atlas::BlockMapParams params;
    params.cell_m = s;
    if (Status st = atlas::buildBlockMap(scene.triangles, params, &out->planes); !st.ok()) throw std::runtime_error(st.error);
    timing["planes_s"] = secondsSince(t0);  // BVH, cells, columns, distance
    const format::BlockMap& bm = out->planes;

    // Wall colours: 4 x 4 rays per wall texel into the side strip (§1.2 step 4),
    // the first hit within 1.5 s, on a caster of their own (its build timed
    // apart); the colour is the building's palette (the texture read that
    // would follow is not done in the spike).
    t0 = Clock::now();
    std::vector<std::array<Vec3d, 3>> tris;
    tris.reserve(scene.triangles.size());
    for (const Triangle& t : scene.triangles) tris.push_back(t.position_local);
    const auto caster = atlas::RayCaster::build(tris);
    timing["wall_bvh_s"] = secondsSince(t0);
    t0 = Clock::now();
    out->walls.assign(static_cast<size_t>(bm.wall_width) * static_cast<size_t>(bm.wall_height) * 3, 0);
    std::vector<uint64_t> hits(bm.columns.size(), 0);
    tbb::parallel_for(size_t{0}, bm.columns.size(), [&](size_t i) {
        const format::BlockMapColumn& col = bm.columns[i];
        const int x = static_cast<int>(col.cell % static_cast<uint32_t>(bm.nx)), y = static_cast<int>(col.cell / static_cast<uint32_t>(bm.nx));
        const int dx = format::kSideDx[col.side], dy = format::kSideDy[col.side];
        const double zb = bm.height(col.base), zt = bm.height(bm.cells[col.cell].top);
        const Vec3d inward{-static_cast<double>(dx), -static_cast<double>(dy), 0};
        // Half a cell outside the side.
        const double ex = bm.origin.x + (x + 0.5 + dx) * s, ey = bm.origin.y + (y + 0.5 + dy) * s;
        for (int r = 0; r < col.rows; ++r) {
            int counted = 0;
            for (int a = 0; a < 4; ++a)
                for (int b = 0; b < 4; ++b) {
                    const double along = (a + 0.5) / 4 - 0.5;
                    const double z = zb + (zt - zb) * (r + (b + 0.5) / 4) / col.rows;
                    const Vec3d o{ex + along * s * std::abs(dy), ey + along * s * std::abs(dx), z};
                    counted += caster->nearest(o, inward, 0, 1.5 * s).hit;
                }
            hits[i] += static_cast<uint64_t>(counted);
            const auto rgb = palette(bm.features[bm.cells[col.cell].feature], 0.55 + 0.1 * col.side + 0.02 * (r % 3));
            std::copy(rgb.begin(), rgb.end(),
                      out->walls.begin() + static_cast<long>(((col.y + r) * static_cast<size_t>(bm.wall_width) + col.x) * 3));
        }
    });
    uint64_t hit_total = 0;
    for (uint64_t h : hits) hit_total += h;
    timing["wall_rays_s"] = secondsSince(t0);
    timing["wall_rays_hit"] = hit_total;
    out->roof.assign(bm.cells.size() * 3, 0);
    for (size_t c = 0; c < bm.cells.size(); ++c)
        if (bm.cells[c].occupied()) {
            const auto rgb = palette(bm.features[bm.cells[c].feature], 1.15);
            std::copy(rgb.begin(), rgb.end(), out->roof.begin() + static_cast<long>(c * 3));
        }
    return timing;
}

// The column table as the GPU gets it (RGBA16UI: x, y, rows, base).
std::vector<uint16_t> columnTable(const format::BlockMap& bm) {
    std::vector<uint16_t> coltab;
    for (const format::BlockMapColumn& c : bm.columns) coltab.insert(coltab.end(), {c.x, c.y, c.rows, c.base});
    return coltab;
}

// Bytes of §1.2's layout: cells RGBA16UI while feature and column indices fit in 16 bits
// (else RGBA32UI), distance R8UI, the column table, ids, colour as BC1; zstd 19 for the non-colour planes.
json blockMapBytes(const format::BlockMap& bm, double* encode_s) {
    auto t0 = Clock::now();
    const bool narrow = bm.features.size() < 0xFFFF && bm.columns.size() < 0xFFFF;
    std::vector<uint32_t> cells32;
    std::vector<uint16_t> cells16;
    for (const format::BlockMapCell& c : bm.cells) {
        cells32.insert(cells32.end(), {c.top, c.base, c.feature, c.first_column});
        cells16.insert(cells16.end(), {c.top, c.base, static_cast<uint16_t>(c.feature), static_cast<uint16_t>(c.first_column)});
    }
    const std::vector<uint16_t> coltab = columnTable(bm);
    json b;
    const size_t cells_raw = narrow ? cells16.size() * 2 : cells32.size() * 4;
    b["cells_zstd"] = narrow ? zstdBytes(cells16.data(), cells_raw) : zstdBytes(cells32.data(), cells_raw);
    b["dist_zstd"] = zstdBytes(bm.dist.data(), bm.dist.size());
    b["coltab_zstd"] = zstdBytes(coltab.data(), coltab.size() * 2);
    b["fids_zstd"] = zstdBytes(bm.features.data(), bm.features.size() * 4);
    const auto bc1 = [](int w, int h) { return static_cast<size_t>((w + 3) / 4) * static_cast<size_t>((h + 3) / 4) * 8; };
    b["roof_bc1"] = bc1(bm.nx, bm.ny);
    b["walls_bc1"] = bc1(bm.wall_width, bm.wall_height);
    size_t total = 0;
    for (const auto& [k, v] : b.items()) total += v.get<size_t>();
    b["total"] = total;
    b["gpu"] = cells_raw + bm.dist.size() + coltab.size() * 2 + bm.features.size() * 4 + b["roof_bc1"].get<size_t>() +
               b["walls_bc1"].get<size_t>();
    b["cells_16_bit"] = narrow;
    *encode_s = secondsSince(t0);
    return b;
}

// ---- GL: the DDA of §1.2 in grid units (a cell is 1, z in cells above z_lo).
const char* kVertex = R"(#version 330 core
layout(location = 0) in vec3 g;
uniform mat4 u_mvp;
out vec3 v_g;
void main() { v_g = g; gl_Position = u_mvp * vec4(g, 1.0); }
)";

const char* kFragment = R"(#version 330 core
in vec3 v_g;
uniform vec3 u_cam;            // camera, grid units
uniform mat4 u_mvp;
uniform ivec2 u_n;             // nx, ny
uniform float u_h;             // box height, grid units
uniform usampler2D u_cells;    // top, base, local feature, first column
uniform usampler2D u_dist;
uniform sampler2D u_roof;
uniform sampler2D u_walls;
uniform usamplerBuffer u_coltab; // x, y0, rows, base
uniform int u_max_steps;
out vec4 o_colour;

float zOf(uint q) { return float(q) / 65535.0 * u_h; }
uint topOf(ivec2 c) {
  if (any(lessThan(c, ivec2(0))) || any(greaterThanEqual(c, u_n))) return 0u;
  return texelFetch(u_cells, c, 0).r;
}
void main() {
  vec3 d = normalize(v_g - u_cam);
  vec3 inv = 1.0 / d;
  // box exit (entry is the rasterised front face)
  vec3 b1 = vec3(vec2(u_n), u_h);
  vec3 ta = (vec3(0.0) - u_cam) * inv, tb = (b1 - u_cam) * inv;
  vec3 tfar = max(ta, tb), tnear = min(ta, tb);
  float t_exit = min(min(tfar.x, tfar.y), tfar.z);
  float t = max(max(tnear.x, tnear.y), tnear.z);
  int face = tnear.z >= max(tnear.x, tnear.y) ? 4 : (tnear.x >= tnear.y ? (d.x > 0.0 ? 1 : 0) : (d.y > 0.0 ? 3 : 2));
  // face: the side of the cell the ray enters through: 0 +x, 1 -x, 2 +y, 3 -y, 4 top
  ivec2 step = ivec2(d.x > 0.0 ? 1 : -1, d.y > 0.0 ? 1 : -1);
  vec3 p = u_cam + d * t;
  ivec2 c = clamp(ivec2(floor(p.xy)), ivec2(0), u_n - 1);
  vec2 tdelta = abs(inv.xy);
  vec2 tmax = (vec2(c + max(step, ivec2(0))) - u_cam.xy) * inv.xy;
  for (int i = 0; i < u_max_steps; ++i) {
    uint D = texelFetch(u_dist, c, 0).r;
    if (D >= 2u) {
      // all cells within D - 1 of c are empty: leave that square at once
      vec2 lo = vec2(c) - float(D - 1u), hi = vec2(c) + float(D);
      vec2 tx = (mix(lo, hi, greaterThan(d.xy, vec2(0.0))) - u_cam.xy) * inv.xy;
      float tl = min(tx.x, tx.y);
      if (tl >= t_exit) discard;
      face = tx.x < tx.y ? (d.x > 0.0 ? 1 : 0) : (d.y > 0.0 ? 3 : 2);
      t = tl;
      p = u_cam + d * t;
      c = ivec2(floor(p.xy));
      if (face == 1) c.x = int(round(p.x)); else if (face == 0) c.x = int(round(p.x)) - 1;
      if (face == 3) c.y = int(round(p.y)); else if (face == 2) c.y = int(round(p.y)) - 1;
      if (any(lessThan(c, ivec2(0))) || any(greaterThanEqual(c, u_n))) discard;
      tmax = (vec2(c + max(step, ivec2(0))) - u_cam.xy) * inv.xy;
      continue;
    }
    float tout = min(min(tmax.x, tmax.y), t_exit);
    if (D == 0u) {
      uvec4 cell = texelFetch(u_cells, c, 0);
      float h = zOf(cell.r), b = zOf(cell.g);
      float zin = u_cam.z + d.z * t, zout = u_cam.z + d.z * tout;
      float thit = -1.0; int hface = face;
      if (face == 4 && zin <= h + 1e-4) { thit = t; }
      else if (zin <= h && zin >= b) { thit = t; }
      else if (zin > h && zout <= h) { thit = t + (h - zin) / d.z; hface = 4; }
      else if (zin < b && zout >= b) { thit = t + (b - zin) / d.z; hface = 5; }
      if (thit >= 0.0) {
        vec3 hit = u_cam + d * thit;
        vec3 colour;
        if (hface == 4) colour = texelFetch(u_roof, c, 0).rgb;
        else if (hface == 5) colour = vec3(0.1);
        else {
          // rank of this side among the cell's exposed sides (+x, -x, +y, -y)
          ivec2 nb[4] = ivec2[4](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
          int rank = 0;
          for (int k = 0; k < hface; ++k) rank += topOf(c + nb[k]) < cell.r ? 1 : 0;
          uvec4 col = texelFetch(u_coltab, int(cell.a) + rank);
          float zb = zOf(col.a);
          int row = clamp(int((hit.z - zb) / max(h - zb, 1e-6) * float(col.b)), 0, int(col.b) - 1);
          colour = texelFetch(u_walls, ivec2(col.r, col.g + uint(row)), 0).rgb;
        }
        vec4 clip = u_mvp * vec4(hit, 1.0);
        gl_FragDepth = 0.5 * clip.z / clip.w + 0.5;
        o_colour = vec4(colour, 1.0);
        return;
      }
    }
    if (tout >= t_exit) discard;
    t = tout;
    if (tmax.x < tmax.y) { c.x += step.x; tmax.x += tdelta.x; face = step.x > 0 ? 1 : 0; }
    else { c.y += step.y; tmax.y += tdelta.y; face = step.y > 0 ? 3 : 2; }
    if (any(lessThan(c, ivec2(0))) || any(greaterThanEqual(c, u_n))) discard;
  }
  o_colour = vec4(1.0, 0.0, 1.0, 1.0);  // out of steps: magenta, so it shows
}
)";

using Mat4 = std::array<double, 16>;  // column-major
Mat4 mul(const Mat4& a, const Mat4& b) {
    Mat4 r{};
    for (int c = 0; c < 4; ++c)
        for (int rr = 0; rr < 4; ++rr)
            for (int k = 0; k < 4; ++k) r[c * 4 + rr] += a[k * 4 + rr] * b[c * 4 + k];
    return r;
}
Vec3d normalised(const Vec3d& v) { return (1.0 / length(v)) * v; }

struct Camera {
    std::string name;
    Vec3d position;  // local frame
    Vec3d look_at;
};

// Camera-relative view-projection (the camera at the origin), 60 degrees vertical.
Mat4 viewProjection(const Camera& cam, double aspect, double near_m, double far_m) {
    const Vec3d f = normalised(cam.look_at - cam.position);
    const Vec3d r = normalised(cross(f, {0, 0, 1}));
    const Vec3d u = cross(r, f);
    const Mat4 view{r.x, u.x, -f.x, 0, r.y, u.y, -f.y, 0, r.z, u.z, -f.z, 0, 0, 0, 0, 1};
    const double k = 1.0 / std::tan(30.0 * M_PI / 180.0);
    const Mat4 proj{k / aspect, 0, 0, 0, 0, k, 0, 0, 0, 0, (far_m + near_m) / (near_m - far_m), -1,
                    0, 0, 2 * far_m * near_m / (near_m - far_m), 0};
    return mul(proj, view);
}

double boxDistance(const Vec3d& p, const Box3d& b) {
    const double dx = std::max({b.min.x - p.x, 0.0, p.x - b.max.x});
    const double dy = std::max({b.min.y - p.y, 0.0, p.y - b.max.y});
    const double dz = std::max({b.min.z - p.z, 0.0, p.z - b.max.z});
    return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// Largest |ndc x| or |ndc y| of the box's corners from `cam`.
double screenExtent(const Camera& cam, const Box3d& b, double aspect) {
    const Mat4 vp = viewProjection(cam, aspect, 1, 1e7);
    double m = 0;
    for (int i = 0; i < 8; ++i) {
        const Vec3d p = Vec3d{i & 1 ? b.max.x : b.min.x, i & 2 ? b.max.y : b.min.y, i & 4 ? b.max.z : b.min.z} - cam.position;
        const double cx = vp[0] * p.x + vp[4] * p.y + vp[8] * p.z + vp[12];
        const double cy = vp[1] * p.x + vp[5] * p.y + vp[9] * p.z + vp[13];
        const double cw = vp[3] * p.x + vp[7] * p.y + vp[11] * p.z + vp[15];
        m = std::max({m, std::abs(cx / cw), std::abs(cy / cw)});
    }
    return m;
}

// From azimuth 30 degrees, elevation 40 degrees, looking at the box centre:
// `switch` at box distance `switch_m`; `full` where the box just fills the
// frame (along one axis); `close` at a third of that, the frame all box;
// `away` at `switch` looking the other way (a frame's cost without the town).
std::vector<Camera> cameras(const Box3d& b, double switch_m, double aspect) {
    const Vec3d centre = 0.5 * (b.min + b.max);
    const double az = 30 * M_PI / 180, el = 40 * M_PI / 180;
    const Vec3d dir{std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)};
    auto at = [&](double r) { return Camera{"", centre + r * dir, centre}; };
    auto bisect = [&](auto&& too_close) {
        double lo = 1, hi = 1e8;
        for (int i = 0; i < 200; ++i) {
            const double mid = std::sqrt(lo * hi);
            (too_close(mid) ? lo : hi) = mid;
        }
        return hi;
    };
    Camera sw = at(bisect([&](double r) { return boxDistance(at(r).position, b) < switch_m; }));
    sw.name = "switch";
    Camera full = at(bisect([&](double r) { return screenExtent(at(r), b, aspect) > 1.0; }));
    full.name = "full";
    // Closer, so the box covers the whole frame: the worst fragment cost.
    Camera close = at(0.35 * length(full.position - centre));
    close.name = "close";
    // Looking away from the town: what a frame costs without it (clear, planning).
    Camera away{"away", sw.position, sw.position + (sw.position - centre)};
    return {sw, full, close, away};
}

GLuint texture2D(GLenum internal, GLenum format, GLenum type, int w, int h, const void* data) {
    GLuint t = 0;
    glGenTextures(1, &t);
    glBindTexture(GL_TEXTURE_2D, t);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, static_cast<GLint>(internal), w, h, 0, format, type, data);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    return t;
}

json renderBlockMap(const SpikeBlockMap& spike, const std::vector<Camera>& cams, int width, int height, int frames,
                    const std::string& out_dir) {
    Status st;
    auto context = render::HeadlessContext::create(&st);
    if (!context) throw std::runtime_error(st.error);
    auto target = render::OffscreenTarget::create(width, height, &st);
    if (!target) throw std::runtime_error(st.error);
    std::string error;
    const GLuint program = render::linkProgram(kVertex, kFragment, &error);
    if (!program) throw std::runtime_error(error);
    const format::BlockMap& bm = spike.planes;
    const double hg = (bm.z_hi - bm.origin.z) / bm.cell_m;
    // Cells as RGBA32UI (top, base, feature, first column): the wide variant, whatever the counts.
    std::vector<uint32_t> cells32;
    for (const format::BlockMapCell& c : bm.cells) cells32.insert(cells32.end(), {c.top, c.base, c.feature, c.first_column});
    const GLuint cells = texture2D(GL_RGBA32UI, GL_RGBA_INTEGER, GL_UNSIGNED_INT, bm.nx, bm.ny, cells32.data());
    const GLuint dist = texture2D(GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, bm.nx, bm.ny, bm.dist.data());
    const GLuint roof = texture2D(GL_SRGB8, GL_RGB, GL_UNSIGNED_BYTE, bm.nx, bm.ny, spike.roof.data());
    const GLuint walls =
        texture2D(GL_SRGB8, GL_RGB, GL_UNSIGNED_BYTE, bm.wall_width, std::max(1, bm.wall_height), spike.walls.data());
    const std::vector<uint16_t> coltab = columnTable(bm);
    GLuint tbo = 0, coltex = 0;
    glGenBuffers(1, &tbo);
    glBindBuffer(GL_TEXTURE_BUFFER, tbo);
    glBufferData(GL_TEXTURE_BUFFER, static_cast<GLsizeiptr>(coltab.size() * 2), coltab.data(), GL_STATIC_DRAW);
    glGenTextures(1, &coltex);
    glBindTexture(GL_TEXTURE_BUFFER, coltex);
    glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA16UI, tbo);
    // The box, grid units.
    const float bx = static_cast<float>(bm.nx), by = static_cast<float>(bm.ny), bz = static_cast<float>(hg);
    const float corners[8][3] = {{0, 0, 0}, {bx, 0, 0}, {0, by, 0}, {bx, by, 0}, {0, 0, bz}, {bx, 0, bz}, {0, by, bz}, {bx, by, bz}};
    const uint16_t idx[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
    GLuint vao = 0, vbo = 0, ebo = 0;
    glGenVertexArrays(1, &vao);
    glBindVertexArray(vao);
    glGenBuffers(1, &vbo);
    glBindBuffer(GL_ARRAY_BUFFER, vbo);
    glBufferData(GL_ARRAY_BUFFER, sizeof(corners), corners, GL_STATIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
    glGenBuffers(1, &ebo);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo);
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, sizeof(idx), idx, GL_STATIC_DRAW);

    json out = json::object();
    out["renderer"] = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    for (const Camera& cam : cams) {
        // grid -> camera-relative world: scale by s, translate by origin - camera (double on the CPU).
        const Vec3d o = bm.origin - cam.position;
        const double s = bm.cell_m;
        const Mat4 model{s, 0, 0, 0, 0, s, 0, 0, 0, 0, s, 0, o.x, o.y, o.z, 1};
        const double dist_m = length(cam.look_at - cam.position);
        const Mat4 mvp = mul(viewProjection(cam, static_cast<double>(width) / height, std::max(1.0, dist_m * 0.01), dist_m * 4), model);
        std::array<float, 16> mvpf{};
        for (int i = 0; i < 16; ++i) mvpf[i] = static_cast<float>(mvp[i]);
        const Vec3d cg = (1.0 / s) * (cam.position - bm.origin);
        target->bind();
        glUseProgram(program);
        glUniformMatrix4fv(glGetUniformLocation(program, "u_mvp"), 1, GL_FALSE, mvpf.data());
        glUniform3f(glGetUniformLocation(program, "u_cam"), static_cast<float>(cg.x), static_cast<float>(cg.y), static_cast<float>(cg.z));
        glUniform2i(glGetUniformLocation(program, "u_n"), bm.nx, bm.ny);
        glUniform1f(glGetUniformLocation(program, "u_h"), static_cast<float>(hg));
        glUniform1i(glGetUniformLocation(program, "u_max_steps"), bm.nx + bm.ny + 8);
        const std::pair<const char*, GLuint> units[5] = {{"u_cells", cells}, {"u_dist", dist}, {"u_roof", roof}, {"u_walls", walls}, {"u_coltab", coltex}};
        for (int u = 0; u < 5; ++u) {
            glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(u));
            glBindTexture(u == 4 ? GL_TEXTURE_BUFFER : GL_TEXTURE_2D, units[u].second);
            glUniform1i(glGetUniformLocation(program, units[u].first), u);
        }
        glEnable(GL_DEPTH_TEST);
        glEnable(GL_CULL_FACE);
        glCullFace(GL_BACK);
        glFrontFace(GL_CCW);
        std::vector<double> ms;
        for (int f = 0; f < frames + 2; ++f) {
            const auto t0 = Clock::now();
            glClearColor(0.55f, 0.7f, 0.9f, 1);
            glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
            glDrawElements(GL_TRIANGLES, 36, GL_UNSIGNED_SHORT, nullptr);
            glFinish();
            if (f >= 2) ms.push_back(secondsSince(t0) * 1000);
        }
        std::sort(ms.begin(), ms.end());
        std::vector<uint8_t> rgba;
        target->readPixels(&rgba);
        size_t covered = 0, magenta = 0;
        for (size_t i = 0; i < rgba.size(); i += 4) {
            covered += !(rgba[i] == rgba[0] && rgba[i + 1] == rgba[1] && rgba[i + 2] == rgba[2]);
            magenta += rgba[i] == 255 && rgba[i + 1] == 0 && rgba[i + 2] == 255;
        }
        const std::string png = out_dir + "/blockmap-" + cam.name + ".png";
        auto img = OIIO::ImageOutput::create(png);
        if (img && img->open(png, OIIO::ImageSpec(width, height, 4, OIIO::TypeDesc::UINT8))) {
            img->write_image(OIIO::TypeDesc::UINT8, rgba.data());
            img->close();
        }
        out[cam.name] = {{"frame_ms_median", ms[ms.size() / 2]}, {"frame_ms_min", ms.front()}, {"frame_ms_max", ms.back()},
                         {"frames", ms.size()}, {"pixels_not_background", covered}, {"pixels_out_of_steps", magenta},
                         {"camera", {{"position", {cam.position.x, cam.position.y, cam.position.z}},
                                     {"look_at", {cam.look_at.x, cam.look_at.y, cam.look_at.z}}}}};
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 5) {
        std::fprintf(stderr, "usage: blockmap_spike BUILDINGS TEXTURE_PX TILE_FOLDER OUT_DIR [WxH] [FRAMES]\n");
        return 2;
    }
    try {
        synth::TownSettings settings;
        settings.buildings = static_cast<uint32_t>(std::stoul(argv[1]));
        settings.texture_size_px = std::stoi(argv[2]);
        settings.seed = 1;
        const std::string folder = argv[3], out_dir = argv[4];
        int width = 1280, height = 720;
        if (argc > 5) std::sscanf(argv[5], "%dx%d", &width, &height);
        const int frames = argc > 6 ? std::stoi(argv[6]) : 10;

        const json tileset = json::parse(std::ifstream(folder + "/tileset.json"));
        const json& root = tileset["root"];
        const json& extras = root["extras"]["cityatlas"];
        const double texel = extras["world_texel_m"], switch_m = extras["min_distance_m"];
        json geometry_bytes = json::object();
        size_t root_bytes = 0;
        for (const auto& [layer, l] : extras["layers"].items()) {
            const size_t g = l["geometry"]["bytes"], a = l.contains("atlas") ? l["atlas"]["bytes"].get<size_t>() : 0;
            geometry_bytes[layer] = {{"geometry", g}, {"atlas", a}, {"triangles", l["triangles"]},
                                     {"triangles_source", l["triangles_source"]}, {"geometric_error_m", l["geometric_error_m"]}};
            root_bytes += g + a;
        }
        const std::vector<uint32_t> dropped = extras["features"]["dropped"];

        auto t0 = Clock::now();
        const Scene scene = synth::townToScene(synth::generateTown(settings), "/nonexistent");
        const double scene_s = secondsSince(t0);
        SpikeBlockMap spike;
        t0 = Clock::now();
        json timing = buildSpike(scene, texel, &spike);
        const format::BlockMap& bm = spike.planes;
        double encode_s = 0;
        json bytes = blockMapBytes(bm, &encode_s);
        timing["encode_s"] = encode_s;
        timing["total_s"] = secondsSince(t0);

        // Plan-view built area (the up-facing triangles projected): every
        // building, those the root's geometry keeps, and the BlockMap's cells.
        std::vector<double> roof_area(scene.features.size(), 0);
        for (const Triangle& t : scene.triangles) {
            const Vec3d n = cross(t.position_local[1] - t.position_local[0], t.position_local[2] - t.position_local[0]);
            if (n.z > 0) roof_area[t.feature] += 0.5 * n.z;
        }
        double built_m2 = 0, dropped_m2 = 0;
        for (double a : roof_area) built_m2 += a;
        for (uint32_t f : dropped) dropped_m2 += roof_area[f];
        std::set<uint32_t> present(bm.features.begin(), bm.features.end());
        size_t dropped_present = 0;
        for (uint32_t f : dropped) dropped_present += present.count(f);
        size_t occupied = 0;
        for (uint8_t v : bm.dist) occupied += v == 0;
        Box3d box;
        const double s = bm.cell_m;
        box.min = bm.origin;
        box.max = {bm.origin.x + bm.nx * s, bm.origin.y + bm.ny * s, bm.z_hi};
        const auto cams = cameras(box, switch_m, static_cast<double>(width) / height);

        json report;
        report["town"] = {{"buildings", settings.buildings}, {"texture_px", settings.texture_size_px},
                          {"features", scene.features.size()}, {"triangles", scene.triangles.size()}, {"scene_s", scene_s}};
        report["root"] = {{"folder", folder}, {"world_texel_m", texel}, {"min_distance_m", switch_m}, {"bytes", root_bytes},
                          {"layers", geometry_bytes}, {"features_drawn", extras["features"]["count"]},
                          {"features_dropped", dropped.size()}};
        report["blockmap"] = {{"grid", {bm.nx, bm.ny}}, {"cell_m", s}, {"z_range", {bm.origin.z, bm.z_hi}},
                              {"occupied_cells", occupied}, {"columns", bm.columns.size()},
                              {"wall_px", {bm.wall_width, bm.wall_height}}, {"features", bm.features.size()},
                              {"dropped_by_geometry_present", dropped_present}, {"bytes", bytes}, {"build", timing},
                              {"voxel_error_bound_m", 0.5 * std::sqrt(2 * s * s + std::pow((bm.z_hi - bm.origin.z) / 65535.0, 2))}};
        report["plan_area_m2"] = {{"buildings", built_m2}, {"root_geometry", built_m2 - dropped_m2},
                                  {"blockmap_cells", static_cast<double>(occupied) * s * s}};
        report["render"] = renderBlockMap(spike, cams, width, height, frames, out_dir);
        report["render"]["size"] = {width, height};
        std::ofstream(out_dir + "/spike.json") << report.dump(1) << "\n";
        json path = {{"interpolation", "linear"}, {"frame_rate", 20}, {"keyframes", json::array()}};
        double time = 0;
        for (const Camera& c : cams)
            for (int rep = 0; rep < 40; ++rep, time += 0.05)
                path["keyframes"].push_back({{"time_s", time}, {"position", {c.position.x, c.position.y, c.position.z}},
                                             {"look_at", {c.look_at.x, c.look_at.y, c.look_at.z}}, {"label", c.name},
                                             {"cut", rep == 0 && time > 0}});
        std::ofstream(out_dir + "/cameras.json") << path.dump(1) << "\n";
        std::printf("%s\n", report.dump(1).c_str());
    } catch (const std::exception& e) {
        std::fprintf(stderr, "blockmap_spike: %s\n", e.what());
        return 1;
    }
    return 0;
}
