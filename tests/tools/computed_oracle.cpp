// SPDX-License-Identifier: GPL-3.0-or-later
// computed_oracle FOLDER: checks a tile folder's computed textures (issue 19)
// against values computed again from the folder alone, as JSON on stdout.
//
// The occluders are every leaf's decoded geometry: the whole scene, not the
// shard-plus-occluders set the build cast against, so a shard that missed an
// occluder shows. For every leaf layer's computed image, each texel whose
// centre lies inside exactly one decoded triangle's atlas image (at least
// `margin` of a texel from its edges, so the build's own triangle, found in
// the tree's undecoded coordinates, is the same one) stands for that
// triangle's point with the same barycentric coordinates; the model of the
// tileset's entry (atlas/computed_layers.h makeSurfaceField, with the
// tileset's georeference and parameters) is evaluated there and compared with
// the decoded BC4 value. A texel is out of tolerance when the difference
// exceeds half a code (quantization) + 1/255 (float rounding of the point)
// + the BC4 error bound of its 4x4 block, (block max - block min) / 14 (8
// interpolated levels, half a step) + one ray of the model (1 / its rays: a
// ray grazing an edge may go the other way from a point the decoded geometry
// moved by a millimetre).
// Texels strictly inside two or more triangles (shared charts) are counted apart.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>

#include <nlohmann/json.hpp>

#include "atlas/computed_layers.h"
#include "atlas/raycast.h"
#include "atlas/sun_hours.h"
#include "format/dds.h"
#include "format/glb_reader.h"
#include "format/tileset_document.h"

namespace fs = std::filesystem;
using namespace cityatlas;

namespace {

std::vector<uint8_t> readAll(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

double cross2(const Vec2d& o, const Vec2d& a, const Vec2d& b) {
    return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: computed_oracle FOLDER [MARGIN_TEXELS]\n");
        return 2;
    }
    const fs::path folder = argv[1];
    const double margin = argc > 2 ? std::atof(argv[2]) : 0.5;
    const std::vector<uint8_t> text_bytes = readAll(folder / "tileset.json");
    format::TilesetDocument doc;
    if (Status s = format::readTilesetDocument(std::string(text_bytes.begin(), text_bytes.end()), "tileset.json", &doc); !s.ok()) {
        std::fprintf(stderr, "computed_oracle: %s\n", s.error.c_str());
        return 1;
    }
    // Every leaf's triangles, decoded: the scene.
    struct LeafMesh {
        size_t tile;
        int layer;
        format::TileMesh mesh;
    };
    std::vector<LeafMesh> leaves;
    std::vector<std::array<Vec3d, 3>> scene;
    std::vector<uint32_t> scene_feature;  // per triangle of `scene`
    for (size_t t = 0; t < doc.tiles.size(); ++t) {
        const format::TileEntry& tile = doc.tiles[t];
        if (!tile.leaf()) continue;
        for (int l = 0; l < format::kTileLayers; ++l) {
            const auto& layer = tile.layers[static_cast<size_t>(l)];
            if (!layer) continue;
            LeafMesh m{t, l, {}};
            if (Status s = format::decodeTileGlb(readAll(folder / layer->geometry.uri), tile.centre, &m.mesh); !s.ok()) {
                std::fprintf(stderr, "computed_oracle: %s: %s\n", layer->geometry.uri.c_str(), s.error.c_str());
                return 1;
            }
            for (size_t i = 0; i + 2 < m.mesh.indices.size(); i += 3) {
                scene.push_back({m.mesh.positions[m.mesh.indices[i]], m.mesh.positions[m.mesh.indices[i + 1]],
                                 m.mesh.positions[m.mesh.indices[i + 2]]});
                scene_feature.push_back(m.mesh.feature_id.empty() ? 0xFFFFFFFFu : m.mesh.feature_id[m.mesh.indices[i]]);
            }
            leaves.push_back(std::move(m));
        }
    }
    const auto caster = atlas::RayCaster::build(scene);
    Georeference georef;
    georef.local_to_ecef = doc.georeference.local_to_ecef;
    georef.enu_to_ecef = doc.georeference.enu_to_ecef;
    nlohmann::json out = nlohmann::json::array();
    for (size_t k = 0; k < doc.computed.size(); ++k) {
        const format::ComputedTextureEntry& entry = doc.computed[k];
        atlas::ComputedSpec spec;
        nlohmann::json spec_json = {{"model", entry.name}, {"parameters", nlohmann::json::parse(entry.parameters_json)}};
        if (Status s = atlas::computedSpecFromJson(spec_json, &spec); !s.ok()) {
            std::fprintf(stderr, "computed_oracle: %s\n", s.error.c_str());
            return 1;
        }
        // A visibility target: its building and parts from the feature tables, its triangles from the leaves.
        std::unique_ptr<atlas::RayCaster> target_caster, target_scene;
        atlas::VisibilityTarget target;
        if (spec.model == atlas::ComputedModel::Visibility) {
            std::map<uint32_t, int64_t> parent;
            std::set<uint32_t> named;
            for (const format::FileEntry& table : doc.feature_tables) {
                const std::vector<uint8_t> bytes = readAll(folder / table.uri);
                const nlohmann::json doc_table = nlohmann::json::parse(bytes.begin(), bytes.end());
                for (const nlohmann::json& f : doc_table.at("features")) {
                    parent[f.at("id").get<uint32_t>()] = f.at("parent").get<int64_t>();
                    if (f.at("gml_id") == spec.building) named.insert(f.at("id").get<uint32_t>());
                }
            }
            auto inTarget = [&](uint32_t f) {
                for (int64_t a = f, guard = 0; a >= 0 && guard < 64; ++guard) {
                    if (named.count(static_cast<uint32_t>(a))) return true;
                    const auto it = parent.find(static_cast<uint32_t>(a));
                    a = it == parent.end() ? -1 : it->second;
                }
                return false;
            };
            std::vector<std::array<Vec3d, 3>> mine, all;
            for (size_t i = 0; i < scene.size(); ++i)
                if (inTarget(scene_feature[i])) mine.push_back(scene[i]);
            all = mine;
            all.insert(all.end(), scene.begin(), scene.end());
            for (const auto& t : mine)
                for (const Vec3d& p : t) target.box.extend(p);
            target.is_target.assign(all.size(), 0);
            std::fill(target.is_target.begin(), target.is_target.begin() + static_cast<std::ptrdiff_t>(mine.size()), 1);
            if (std::getenv("ORACLE_DEBUG")) std::fprintf(stderr, "target %s: %zu features named, %zu triangles\n", spec.building.c_str(), named.size(), mine.size());
            target_caster = atlas::RayCaster::build(mine);
            target_scene = atlas::RayCaster::build(all);
            target.target = target_caster.get(), target.scene = target_scene.get();
            target.grid = spec.grid, target.horizon_m = spec.horizon_m;
        }
        atlas::SurfaceField field;
        if (Status s = atlas::makeSurfaceField(spec, *caster, georef, &field, &target); !s.ok()) {
            std::fprintf(stderr, "computed_oracle: %s\n", s.error.c_str());
            return 1;
        }
        // One ray's worth of the model: a ray that grazes an edge may go the
        // other way at a point the decoded geometry moved by a millimetre.
        double rays = spec.directions;
        if (spec.model == atlas::ComputedModel::Shadow) rays = spec.disc.samples;
        // Visibility: a ratio of the grid's rays that hit the target, at least a few dozen.
        if (spec.model == atlas::ComputedModel::Visibility) rays = 32;
        if (spec.model == atlas::ComputedModel::SunHours) {
            const auto frame = atlas::sunFrame(georef);
            atlas::SunSchedule schedule;
            schedule.latitude_deg = frame->latitude_deg, schedule.longitude_deg = frame->longitude_deg;
            schedule.year = spec.year, schedule.days = spec.days, schedule.step_minutes = spec.step_minutes;
            rays = static_cast<double>(atlas::daylightSunDirections(schedule).size());
        }
        uint64_t compared = 0, over = 0, shared = 0, files = 0;
        double sum_abs = 0, max_abs = 0;
        for (const LeafMesh& m : leaves) {
            const auto& layer = *doc.tiles[m.tile].layers[static_cast<size_t>(m.layer)];
            if (k >= layer.computed.size() || layer.computed[k].file.uri.empty() || m.mesh.uv_atlas.empty()) continue;
            const format::ComputedFileEntry& c = layer.computed[k];
            const std::vector<uint8_t> dds = readAll(folder / c.file.uri);
            format::DdsInfo info;
            if (Status s = format::parseDdsHeader(dds.data(), dds.size(), &info); !s.ok() || info.channels != 1) {
                std::fprintf(stderr, "computed_oracle: %s: not BC4\n", c.file.uri.c_str());
                return 1;
            }
            ++files;
            const int w = info.width, h = info.height;
            const auto begin = dds.begin() + static_cast<long>(info.header_bytes);
            const format::Image8 img = format::decodeBc(
                std::vector<uint8_t>(begin, begin + static_cast<long>(format::bcBlockBytes(w, h, 1))), w, h, 1);
            auto code = [&](int x, int y) {  // y up
                return img.pixels[static_cast<size_t>(h - 1 - y) * static_cast<size_t>(w) + static_cast<size_t>(x)];
            };
            // Triangles in computed-texel space.
            struct Tri {
                std::array<Vec2d, 3> t;
                std::array<Vec3d, 3> p;
                double area;
            };
            std::vector<Tri> tris;
            for (size_t i = 0; i + 2 < m.mesh.indices.size(); i += 3) {
                Tri tri;
                for (int v = 0; v < 3; ++v) {
                    const uint32_t ix = m.mesh.indices[i + static_cast<size_t>(v)];
                    tri.t[static_cast<size_t>(v)] = {m.mesh.uv_atlas[ix].x * w, m.mesh.uv_atlas[ix].y * h};
                    tri.p[static_cast<size_t>(v)] = m.mesh.positions[ix];
                }
                tri.area = cross2(tri.t[0], tri.t[1], tri.t[2]);
                if (m.mesh.texture_id.empty() || m.mesh.texture_id[m.mesh.indices[i]] < 0) continue;  // untextured
                if (std::abs(tri.area) > 1e-12) tris.push_back(tri);
            }
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    const Vec2d q{x + 0.5, y + 0.5};
                    const Tri* hit = nullptr;
                    int inside = 0;
                    std::array<double, 3> bary{};
                    for (const Tri& tri : tris) {
                        std::array<double, 3> b{cross2(q, tri.t[1], tri.t[2]) / tri.area,
                                                cross2(tri.t[0], q, tri.t[2]) / tri.area,
                                                cross2(tri.t[0], tri.t[1], q) / tri.area};
                        const double least = std::min({b[0], b[1], b[2]});
                        if (least < 0) continue;
                        // On an edge two triangles of one chart share: not a shared texel.
                        if (least > 1e-6) ++inside;
                        // Distance to the nearest edge, in texels: barycentric / |gradient|.
                        double edge = 1e300;
                        for (int e = 0; e < 3; ++e) {
                            const Vec2d& a = tri.t[static_cast<size_t>((e + 1) % 3)];
                            const Vec2d& bb = tri.t[static_cast<size_t>((e + 2) % 3)];
                            const double len = std::hypot(bb.x - a.x, bb.y - a.y);
                            edge = std::min(edge, std::abs(b[static_cast<size_t>(e)] * tri.area) / len);
                        }
                        if (edge >= margin) hit = &tri, bary = b;
                    }
                    if (inside > 1) {
                        ++shared;
                        continue;
                    }
                    if (!hit) continue;
                    atlas::TexelSurface s;
                    s.point = bary[0] * hit->p[0] + bary[1] * hit->p[1] + bary[2] * hit->p[2];
                    s.normal = cross(hit->p[1] - hit->p[0], hit->p[2] - hit->p[0]);
                    if (!(length(s.normal) > 0)) continue;
                    s.normal = (1.0 / length(s.normal)) * s.normal;
                    s.covered = true;
                    const double want = field(s);
                    const double got = code(x, y) / 255.0;
                    int lo = 255, hi = 0;
                    for (int by = y / 4 * 4; by < std::min(h, y / 4 * 4 + 4); ++by)
                        for (int bx = x / 4 * 4; bx < std::min(w, x / 4 * 4 + 4); ++bx)
                            lo = std::min<int>(lo, code(bx, by)), hi = std::max<int>(hi, code(bx, by));
                    const double tol = 0.5 / 255 + 1.0 / 255 + (hi - lo) / 255.0 / 14.0 + 1.0 / rays;
                    const double d = std::abs(got - want);
                    ++compared;
                    sum_abs += d, max_abs = std::max(max_abs, d);
                    if (d > tol) ++over;
                    if (std::getenv("ORACLE_DEBUG") && compared < 40)
                        std::fprintf(stderr, "texel %d,%d of %dx%d: got %.3f want %.3f normal %.2f %.2f %.2f point %.1f %.1f %.1f\n", x, y, w, h, got, want,
                                     s.normal.x, s.normal.y, s.normal.z, s.point.x, s.point.y, s.point.z);
                }
        }
        out.push_back({{"name", entry.name},
                       {"files", files},
                       {"texels", compared},
                       {"shared_texels", shared},
                       {"mean_abs", compared ? sum_abs / static_cast<double>(compared) : 0.0},
                       {"max_abs", max_abs},
                       {"over_tolerance", over},
                       {"fraction_over", compared ? static_cast<double>(over) / static_cast<double>(compared) : 0.0}});
    }
    std::printf("%s\n", out.dump(1).c_str());
    return 0;
}
