// SPDX-License-Identifier: GPL-3.0-or-later
// The tile folder of tiles/tileset.h: geometry bottom-up, atlases, original
// texture blocks, feature tables, then tileset.json (a format::TilesetDocument,
// serialized by the format library that the client and `inspect` read it with).

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>

#include <draco/core/draco_version.h>
#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include "cityatlas_version.h"
#include "core/resource_usage.h"
#include "format/tileset_document.h"
#include "tiles/feature_bounds.h"
#include "tiles/node_geometry.h"
#include "tiles/texture_blocks.h"
#include "tiles/tileset.h"

namespace cityatlas::tiles {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using atlas::AtlasNode;
using atlas::AtlasTree;
using atlas::Layer;

Vec3d centreOf(const Box3d& b) { return 0.5 * (b.min + b.max); }

// Distinct feature ids of the triangles that survive encoding (encodeTileGlb
// drops triangles with two corners at one float32 position).
std::vector<uint32_t> encodedFeatures(const TileMesh& m, const Vec3d& centre) {
    auto f32 = [&](uint32_t i) {
        const Vec3d r = m.positions[i] - centre;
        return std::array<float, 3>{static_cast<float>(r.x), static_cast<float>(r.y), static_cast<float>(r.z)};
    };
    std::vector<uint32_t> f;
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
        const auto a = f32(m.indices[t]), b = f32(m.indices[t + 1]), c = f32(m.indices[t + 2]);
        if (a == b || b == c || a == c) continue;
        f.push_back(m.feature_id[m.indices[t]]);
    }
    std::sort(f.begin(), f.end());
    f.erase(std::unique(f.begin(), f.end()), f.end());
    return f;
}

std::vector<uint32_t> unionOf(const std::vector<uint32_t>& a, const std::vector<uint32_t>& b) {
    std::vector<uint32_t> u;
    std::set_union(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(u));
    return u;
}

// The fewest quantization bits whose worst-case error over the mesh's
// extent (sqrt(3) half steps) stays within 90 % of `target` metres.
int bitsFor(const TileMesh& m, const Vec3d& centre, double target) {
    Box3d b;
    for (const Vec3d& p : m.positions) b.extend(p - centre);
    const Vec3d size = b.max - b.min;
    const double extent = std::max({size.x, size.y, size.z});
    for (int bits = 1; bits < 30; ++bits)
        if (std::sqrt(3.0) * 0.5 * extent / static_cast<double>((uint64_t{1} << bits) - 1) <= 0.9 * target) return bits;
    return 30;
}

// Texels per unit of u or v (the larger side) of the scene's tileset
// textures, by tileset number, ascending: a shard's scene holds its own
// textures, numbered as the whole city's tileset numbers them.
using TextureSizes = std::vector<std::pair<int32_t, double>>;
TextureSizes textureSizes(const Scene& scene, const TextureIndex& texture_index, int atlas_size_px, bool split) {
    TextureSizes sizes;
    for (size_t s = 0; s < texture_index.size(); ++s) {
        const int32_t t = texture_index[s];
        if (t < 0) continue;
        const std::vector<TexelRect> entries = tilesetEntries(scene.textures[s], atlas_size_px, split);
        for (size_t k = 0; k < entries.size(); ++k)
            sizes.emplace_back(t + static_cast<int32_t>(k), std::max(entries[k].width(), entries[k].height()));
    }
    std::sort(sizes.begin(), sizes.end());
    return sizes;
}
// Tileset texture `t`'s size in `sizes`; 0 unknown.
double textureSize(const TextureSizes& sizes, int32_t t) {
    const auto it = std::lower_bound(sizes.begin(), sizes.end(), std::pair<int32_t, double>{t, -1e300});
    return it != sizes.end() && it->first == t ? it->second : 0.0;
}

// The fewest bits for a leaf's original uvs whose worst-case error (half a
// step over the uv extent) stays within 90 % of `target` texels of the largest
// texture the leaf uses; at least `floor`. A texture repeated hundreds of
// times in one triangle widens the extent far beyond [0, 1].
int uvOriginalBitsFor(const TileMesh& m, const TextureSizes& texture_sizes, double target, int floor,
                      double* largest_texture) {
    double lo = 1e300, hi = -1e300, texels = 0;
    int32_t last = -1;  // vertices come a texture's triangles at a time: one look-up each
    for (size_t v = 0; v < m.uv_original.size(); ++v) {
        const int32_t t = m.texture_id[v];
        if (t < 0) continue;
        lo = std::min({lo, m.uv_original[v].x, m.uv_original[v].y});
        hi = std::max({hi, m.uv_original[v].x, m.uv_original[v].y});
        if (t != last) texels = std::max(texels, textureSize(texture_sizes, t)), last = t;
    }
    *largest_texture = texels;
    if (hi < lo || texels <= 0 || target <= 0) return floor;
    for (int bits = floor; bits < 30; ++bits)
        if (0.5 * (hi - lo) / static_cast<double>((uint64_t{1} << bits) - 1) * texels <= 0.9 * target) return bits;
    return 30;
}

}  // namespace

// C stdio, for the errno of a failure (a full disk often shows only at fclose).
Status writeBytes(const fs::path& path, const void* data, size_t size) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return Status::Io(fmt::format("{}: cannot create: {}", path.string(), std::strerror(errno)));
    const bool written = std::fwrite(data, 1, size, f) == size;
    const int write_errno = errno;
    const bool closed = std::fclose(f) == 0;
    if (!written || !closed)
        return Status::Io(fmt::format("{}: cannot write: {}", path.string(), std::strerror(!written ? write_errno : errno)));
    return Status::Ok();
}

Status readBytes(const fs::path& path, std::vector<uint8_t>* out) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return Status::Io(fmt::format("{}: cannot open: {}", path.string(), std::strerror(errno)));
    out->assign(std::istreambuf_iterator<char>(f), {});
    if (f.bad()) return Status::Io(fmt::format("{}: cannot read", path.string()));
    return Status::Ok();
}

double textureRatio(const TilesStats& s) {
    return s.bytes_originals_bc ? static_cast<double>(s.bytes_atlases + s.bytes_textures) / static_cast<double>(s.bytes_originals_bc)
                                : 0.0;
}

Status encodeAtlas(const Image8& image, int32_t node, Layer layer, BcQuality quality, const fs::path& out_dir,
                   EncodedAtlas* out) {
    EncodedAtlas a;
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<Image8> mips = mipChain(image);
    const std::vector<uint8_t> dds = encodeDds(mips, quality);
    a.encode_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (const Image8& m : mips) a.texels += static_cast<uint64_t>(m.width) * m.height;
    constexpr size_t kDdsHeader = 128;
    const std::vector<uint8_t> level0(dds.begin() + kDdsHeader,
                                      dds.begin() + kDdsHeader + bcBlockBytes(image.width, image.height, image.channels));
    a.psnr_db = psnrRgb(image, decodeBc(level0, image.width, image.height, image.channels));
    a.uri = fmt::format("atlas/{}/{}.dds", atlas::layerName(layer), node);
    const fs::path path = out_dir / a.uri;
    std::error_code ec;
    fs::create_directories(path.parent_path(), ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", path.parent_path().string(), ec.message()));
    if (Status w = writeBytes(path, dds.data(), dds.size()); !w.ok()) return w;
    a.bytes = dds.size();
    a.mips = static_cast<int>(mips.size());
    *out = std::move(a);
    return Status::Ok();
}

AtlasHandOff::AtlasHandOff(BcQuality quality, fs::path out_dir, fs::path png_dir)
    : quality_(quality), out_dir_(std::move(out_dir)), png_dir_(std::move(png_dir)) {}

atlas::AtlasImageSink AtlasHandOff::sink() {
    return [this](int32_t node, Layer layer, const Image8& image) {
        EncodedAtlas a;
        if (Status s = encodeAtlas(image, node, layer, quality_, out_dir_, &a); !s.ok()) return s;
        if (!png_dir_.empty()) {
            const fs::path png = png_dir_ / fmt::format("atlas/{}/{}.png", atlas::layerName(layer), node);
            std::error_code ec;
            fs::create_directories(png.parent_path(), ec);
            if (Status s = atlas::writeAtlasPng(image, png); !s.ok()) return s;
        }
        std::lock_guard lock(mutex_);
        by_node_[node][static_cast<size_t>(layer)] = std::move(a);
        return Status::Ok();
    };
}

EncodedAtlases AtlasHandOff::take(size_t nodes) {
    std::lock_guard lock(mutex_);
    EncodedAtlases encoded(nodes);
    for (auto& [node, layers] : by_node_)
        if (node >= 0 && static_cast<size_t>(node) < nodes) encoded[static_cast<size_t>(node)] = std::move(layers);
    by_node_.clear();
    return encoded;
}

namespace {

// The geometry and atlas files of every node of `tree` that `built` does not
// hold, and every node's features and dropped features: the part of the
// tiles stage a shard runs on its own subtree.
Status writeNodeFiles(const Scene& scene, const AtlasTree& tree, const fs::path& atlas_dir, const TilesParams& params,
                      const TextureIndex& texture_index, const fs::path& out_dir, const EncodedAtlases* encoded,
                      BuiltSubtrees* built, const std::function<void(const char*, uint64_t, uint64_t)>& report,
                      tbb::task_arena& arena, std::vector<NodeRecord>& records, SubtreeFiles* root_out) {
    const size_t n_nodes = tree.nodes.size();
    const double ppm = tree.projection.pixelsPerMetreAt1m();
    std::error_code ec;
    for (const char* dir : {"geometry/opaque", "geometry/alpha", "atlas/opaque", "atlas/alpha"}) {
        fs::create_directories(out_dir / dir, ec);
        if (ec) return Status::Io(fmt::format("{}: cannot create: {}", (out_dir / dir).string(), ec.message()));
    }
    auto isBuilt = [&](size_t id) { return built && id < built->built.size() && built->built[id]; };
    // Only a leaf's uv bits need the textures' sizes (one a texture of the
    // city): a merge, whose nodes are all inner ones, does without.
    bool makes_leaves = false;
    for (size_t id = 0; id < n_nodes && !makes_leaves; ++id) makes_leaves = !isBuilt(id) && tree.nodes[id].leaf();
    const TextureSizes texture_sizes =
        makes_leaves ? textureSizes(scene, texture_index, tree.params.atlas_size_px, params.split_originals)
                     : TextureSizes{};

    // --- Geometry, children before their parent: a node merges its
    // children's geometry, which goes as soon as it is merged. Subtrees
    // run as tasks, so what is alive at once is the nodes waiting for a
    // sibling (not whole levels of the tree), and a large merge near the
    // root runs while other subtrees are still busy (no barrier per level).
    // A node a shard built hands over its root geometry instead.
    std::vector<std::array<std::unique_ptr<NodeGeometry>, atlas::kLayerCount>> geometry(n_nodes);
    std::atomic<uint64_t> nodes_done{0};
    auto buildNode = [&](const int32_t id) {
        const AtlasNode& node = tree.nodes[static_cast<size_t>(id)];
        NodeRecord& rec = records[static_cast<size_t>(id)];
        const double texel = node.min_distance_m / ppm;
        const Vec3d centre = centreOf(node.bounds);
        // One layer: its geometry (a leaf's triangles, or the children's
        // merged) encoded and written.
        auto buildLayer = [&](const int li, std::array<std::unique_ptr<NodeGeometry>, 4> children) {
            const auto layer = static_cast<Layer>(li);
            std::unique_ptr<NodeGeometry> g;
            if (node.leaf())
                g = std::make_unique<NodeGeometry>(leafGeometry(scene, tree, id, layer, texture_index, params.split_originals));
            else
                g = std::make_unique<NodeGeometry>(
                    innerGeometry(tree, id, layer, std::move(children), params.node_triangles, texel));
            if (g->empty()) return;
            TileMesh mesh = g->mesh;  // the file's copy: inner nodes draw with the atlas only
            if (!node.leaf()) mesh.texture_id.clear();
            GlbResult glb;
            json extras = {{"cityatlas", {{"layer", std::string(atlas::layerName(layer))},
                                          {"centre", {centre.x, centre.y, centre.z}}}}};
            DracoSettings draco = params.draco;
            const double target = params.position_error_target_m;
            const int useful_bits = usefulPositionBits(mesh, centre);
            if (target > 0)
                draco.position_bits = std::max(draco.position_bits, std::min(bitsFor(mesh, centre, target), useful_bits));
            const double uv_target = params.uv_original_error_target_texels;
            double texels = 0;  // of the leaf's largest texture
            if (node.leaf() && !mesh.uv_original.empty())
                draco.uv_original_bits = uvOriginalBitsFor(mesh, texture_sizes, uv_target, draco.uv_bits, &texels);
            if (drawableTriangles(mesh, centre) == 0) return;  // every triangle degenerate in float32
            Status st = encodeTileGlb(mesh, centre, draco, &glb, extras);
            // The predictions leave room for float32 rounding; should they not
            // suffice, the measurements decide.
            const int most_bits = std::max(draco.position_bits, useful_bits);
            while (st.ok() && target > 0 && glb.max_position_error_m > target && draco.position_bits < most_bits) {
                ++draco.position_bits;
                st = encodeTileGlb(mesh, centre, draco, &glb, extras);
            }
            while (st.ok() && uv_target > 0 && texels > 0 && glb.max_uv_original_error * texels > uv_target &&
                   draco.uv_original_bits < 30) {
                ++draco.uv_original_bits;
                st = encodeTileGlb(mesh, centre, draco, &glb, extras);
            }
            if (!st.ok()) {
                rec.error = fmt::format("node {} ({}): {}", id, atlas::layerName(layer), st.error);
                return;
            }
            LayerRecord& lr = rec.layers[static_cast<size_t>(li)];
            lr.present = true;
            lr.geometry_uri = fmt::format("geometry/{}/{}.glb", atlas::layerName(layer), id);
            if (Status w = writeBytes(out_dir / lr.geometry_uri, glb.bytes.data(), glb.bytes.size()); !w.ok()) {
                rec.error = w.error;
                return;
            }
            lr.geometry_bytes = glb.bytes.size();
            lr.triangles = glb.triangles;
            lr.triangles_source = g->triangles_source;
            lr.geometric_error_m = g->geometric_error_m;
            lr.simplified = g->simplified;
            lr.left_out_over_cap = g->left_out_over_cap;
            lr.position_error_m = glb.max_position_error_m;
            lr.position_bits = draco.position_bits;
            lr.uv_atlas_error_texels = glb.max_uv_atlas_error * std::max(node.layers[static_cast<size_t>(li)].width,
                                                                        node.layers[static_cast<size_t>(li)].height);
            if (!mesh.uv_original.empty()) {
                lr.uv_original_error_texels = glb.max_uv_original_error * texels;
                lr.uv_original_bits = draco.uv_original_bits > 0 ? draco.uv_original_bits : draco.uv_bits;
            }
            rec.features = unionOf(rec.features, encodedFeatures(mesh, centre));
            geometry[static_cast<size_t>(id)][static_cast<size_t>(li)] = std::move(g);
        };
        for (int li = 0; li < atlas::kLayerCount; ++li) {
            if (node.layers[static_cast<size_t>(li)].range.count == 0) continue;
            std::array<std::unique_ptr<NodeGeometry>, 4> children{};  // merged, then freed
            if (!node.leaf())
                for (size_t q = 0; q < 4; ++q)
                    if (node.children[q] >= 0)
                        children[q] = std::move(geometry[static_cast<size_t>(node.children[q])][static_cast<size_t>(li)]);
            const size_t estimate = mergeEstimateBytes(children, params.node_triangles);
            if (estimate == 0) {
                buildLayer(li, std::move(children));
                continue;
            }
            // A large merge waits until it fits beside the others running;
            // isolated, so its thread takes no other node's merge while its
            // own parallel work finishes (core/memory_gate.h).
            const MemoryGate::Held held(mergeGate(), estimate);
            tbb::this_task_arena::isolate([&] { buildLayer(li, std::move(children)); });
        }
        report("tiles: geometry", ++nodes_done, n_nodes);
    };
    std::function<void(int32_t)> visit = [&](const int32_t id) {
        if (isBuilt(static_cast<size_t>(id))) {
            if (built->root_geometry)  // a shard's root: the visit goes no deeper
                if (Status s = built->root_geometry(id, &geometry[static_cast<size_t>(id)]); !s.ok())
                    records[static_cast<size_t>(id)].error = s.error;
            return;
        }
        const AtlasNode& node = tree.nodes[static_cast<size_t>(id)];
        tbb::task_group children;
        for (const int32_t c : node.children)
            if (c >= 0) children.run([&visit, c] { visit(c); });
        children.wait();
        buildNode(id);
        if (id == 0 && root_out) return;  // the shard's root geometry goes to its merge
        for (const int32_t c : node.children)
            if (c >= 0) geometry[static_cast<size_t>(c)] = {};
    };
    arena.execute([&] { visit(0); });
    if (root_out) root_out->root_geometry = std::move(geometry[0]);
    geometry.clear();
    for (const NodeRecord& r : records)
        if (!r.error.empty()) return Status::Io("tiles: " + r.error);

    // Subtree features (both layers), for the dropped lists: bottom-up unions.
    {
        std::vector<std::vector<uint32_t>> subtree(n_nodes);
        for (size_t i = n_nodes; i-- > 0;) {
            const AtlasNode& node = tree.nodes[i];
            std::vector<uint32_t>& s = subtree[i];
            if (isBuilt(i)) {
                if (auto it = built->subtree_features.find(static_cast<int32_t>(i)); it != built->subtree_features.end())
                    s = std::move(it->second);
                continue;  // its records came with it
            }
            if (node.leaf()) {
                for (const auto& layer : node.layers)
                    for (uint32_t t = layer.range.first; t < layer.range.first + layer.range.count; ++t)
                        s.push_back(tree.triangles[t].tri.feature);
                std::sort(s.begin(), s.end());
                s.erase(std::unique(s.begin(), s.end()), s.end());
            } else {
                for (int32_t c : node.children)
                    if (c >= 0) s = unionOf(s, subtree[static_cast<size_t>(c)]);
            }
            std::set_difference(s.begin(), s.end(), records[i].features.begin(), records[i].features.end(),
                                std::back_inserter(records[i].dropped));
            for (int32_t c : node.children)
                if (c >= 0) subtree[static_cast<size_t>(c)].clear();
        }
        if (root_out) root_out->root_subtree_features = std::move(subtree[0]);
    }

    // --- Atlases: encoded during the atlas stage, or PNG from it -> DDS with its mip chain.
    std::vector<std::pair<int32_t, int>> atlas_jobs;
    for (size_t i = 0; i < n_nodes; ++i)
        for (int li = 0; li < atlas::kLayerCount; ++li)
            if (!isBuilt(i) && tree.nodes[i].layers[static_cast<size_t>(li)].present() &&
                records[i].layers[static_cast<size_t>(li)].present)
                atlas_jobs.emplace_back(static_cast<int32_t>(i), li);
    std::vector<std::string> atlas_errors(atlas_jobs.size());
    std::vector<EncodedAtlas> atlases(atlas_jobs.size());
    if (encoded) {
        for (size_t k = 0; k < atlas_jobs.size(); ++k) {
            const auto [id, li] = atlas_jobs[k];
            if (static_cast<size_t>(id) < encoded->size())
                atlases[k] = (*encoded)[static_cast<size_t>(id)][static_cast<size_t>(li)];
            if (atlases[k].uri.empty())
                atlas_errors[k] = fmt::format("node {} ({}): the atlas stage encoded no atlas", id,
                                              atlas::layerName(static_cast<Layer>(li)));
        }
        // Atlases of layers whose geometry came out empty (every triangle degenerate in float32) go.
        for (size_t i = 0; i < encoded->size() && i < n_nodes; ++i)
            for (int li = 0; li < atlas::kLayerCount; ++li)
                if (!isBuilt(i) && !(*encoded)[i][static_cast<size_t>(li)].uri.empty() &&
                    !records[i].layers[static_cast<size_t>(li)].present)
                    fs::remove(out_dir / (*encoded)[i][static_cast<size_t>(li)].uri, ec);
    } else {
        std::atomic<uint64_t> atlases_done{0};
        arena.execute([&] {
            tbb::parallel_for(size_t{0}, atlas_jobs.size(), [&](size_t k) {
                const auto [id, li] = atlas_jobs[k];
                const atlas::NodeLayer& nl = tree.nodes[static_cast<size_t>(id)].layers[static_cast<size_t>(li)];
                Image8 img;
                std::string why;
                const fs::path png = atlas_dir / nl.atlas_path;
                if (!readImage8(png.string(), li == static_cast<int>(Layer::Alpha) ? 4 : 3, &img, &why)) {
                    atlas_errors[k] = fmt::format("{}: cannot read the atlas: {}", png.string(), why);
                    return;
                }
                if (Status w = encodeAtlas(img, id, static_cast<Layer>(li), params.bc_quality, out_dir, &atlases[k]); !w.ok())
                    atlas_errors[k] = w.error;
                report("tiles: atlases", ++atlases_done, atlas_jobs.size());
            });
        });
    }
    for (const std::string& e : atlas_errors)
        if (!e.empty()) return Status::Io("tiles: " + e);
    for (size_t k = 0; k < atlas_jobs.size(); ++k) {
        const auto [id, li] = atlas_jobs[k];
        LayerRecord& lr = records[static_cast<size_t>(id)].layers[static_cast<size_t>(li)];
        lr.atlas_uri = atlases[k].uri;
        lr.atlas_bytes = atlases[k].bytes;
        lr.atlas_mips = atlases[k].mips;
        lr.atlas_psnr_db = atlases[k].psnr_db;
        lr.atlas_encode_seconds = atlases[k].encode_seconds;
        lr.atlas_texels = atlases[k].texels;
    }
    return Status::Ok();
}

}  // namespace

FeatureTablesWriter::FeatureTablesWriter(fs::path out_dir, int block_size)
    : out_dir_(std::move(out_dir)), block_size_(static_cast<size_t>(std::max(1, block_size))) {}

Status FeatureTablesWriter::add(Feature&& f, const format::FeatureBoundsRecord& bounds) {
    block_.push_back(std::move(f));
    boxes_.push_back(bounds);
    return block_.size() == block_size_ ? flush() : Status::Ok();
}

Status FeatureTablesWriter::flush() {
    if (!created_) {
        std::error_code ec;
        fs::create_directories(out_dir_ / "features" / "bounds", ec);
        if (ec)
            return Status::Io(fmt::format("{}: cannot create: {}", (out_dir_ / "features" / "bounds").string(), ec.message()));
        created_ = true;
    }
    if (block_.empty()) return Status::Ok();
    const uint64_t first = tables_.features;
    json list = json::array();
    for (size_t i = 0; i < block_.size(); ++i) {
        const Feature& f = block_[i];
        json j = {{"id", first + i},
                  {"gml_id", f.gml_id},
                  {"name", f.name},
                  {"source_file", f.source_file},
                  {"parent", f.parent},
                  {"lod", f.lod},
                  {"roof_type", f.roof_type},
                  {"function", f.function},
                  {"attributes", f.attributes}};
        j["measured_height_m"] = f.measured_height_m ? json(*f.measured_height_m) : json(nullptr);
        list.push_back(std::move(j));
    }
    const std::string text =
        json({{"first", first}, {"features", list}}).dump(-1, ' ', false, json::error_handler_t::replace) + "\n";
    const size_t table = tables_.tables.size();
    const std::string uri = fmt::format("features/{}.json", table);
    if (Status w = writeBytes(out_dir_ / uri, text.data(), text.size()); !w.ok()) return w;
    tables_.tables.push_back({uri, text.size()});
    const std::vector<uint8_t> box_bytes = format::encodeFeatureBounds(boxes_);
    const std::string box_uri = fmt::format("features/bounds/{}.bin", table);
    if (Status w = writeBytes(out_dir_ / box_uri, box_bytes.data(), box_bytes.size()); !w.ok()) return w;
    tables_.bounds.push_back({box_uri, box_bytes.size()});
    tables_.features += block_.size();
    block_.clear();
    boxes_.clear();
    return Status::Ok();
}

Status readFeatureTables(const fs::path& folder, const std::vector<format::FileEntry>& tables, std::vector<Feature>* out) {
    for (const format::FileEntry& table : tables) {
        const fs::path path = folder / table.uri;
        std::vector<uint8_t> bytes;
        if (Status s = readBytes(path, &bytes); !s.ok()) return s;
        try {
            const json j = json::parse(bytes.begin(), bytes.end());
            if (j.at("first").get<uint64_t>() != out->size())
                return Status::Io(fmt::format("{}: starts at feature {}, expected {}", path.string(),
                                              j.at("first").get<uint64_t>(), out->size()));
            for (const json& x : j.at("features")) {
                Feature f;
                f.gml_id = x.at("gml_id");
                f.name = x.at("name");
                f.source_file = x.at("source_file");
                f.parent = x.at("parent");
                f.lod = x.at("lod");
                f.roof_type = x.at("roof_type");
                f.function = x.at("function");
                f.attributes = x.at("attributes").get<std::map<std::string, std::string>>();
                if (!x.at("measured_height_m").is_null()) f.measured_height_m = x.at("measured_height_m").get<double>();
                out->push_back(std::move(f));
            }
        } catch (const std::exception& e) {
            return Status::Io(fmt::format("{}: not a feature table: {}", path.string(), e.what()));
        }
    }
    return Status::Ok();
}

Status FeatureTablesWriter::finish(FeatureTables* out) {
    if (Status s = flush(); !s.ok()) return s;
    *out = std::move(tables_);
    tables_ = {};
    return Status::Ok();
}

Status writeFeatureTables(const std::vector<Feature>& features, std::span<const format::FeatureBoundsRecord> bounds,
                          int block_size, const fs::path& out_dir, FeatureTables* out) {
    if (bounds.size() != features.size())
        return Status::Invalid(fmt::format("feature tables: {} bounds records for {} features", bounds.size(), features.size()));
    FeatureTablesWriter writer(out_dir, block_size);
    for (size_t id = 0; id < features.size(); ++id)
        if (Status s = writer.add(Feature(features[id]), bounds[id]); !s.ok()) return s;
    return writer.finish(out);
}

Status writeSubtreeFiles(const Scene& scene, const AtlasTree& tree, const fs::path& atlas_dir, const TilesParams& params,
                         const TextureIndex& texture_index, const fs::path& out_dir,
                         const TilesProgressFn& progress, const EncodedAtlases* encoded, SubtreeFiles* out) {
    if (tree.nodes.empty()) return Status::Io("tiles: the atlas tree has no nodes");
    std::mutex progress_mutex;
    auto report = [&](const char* step, uint64_t done, uint64_t total) {
        if (!progress) return;
        std::lock_guard lock(progress_mutex);
        progress(step, done, total);
    };
    tbb::task_arena arena(params.threads > 0 ? params.threads : tbb::task_arena::automatic);
    out->records.assign(tree.nodes.size(), {});
    return writeNodeFiles(scene, tree, atlas_dir, params, texture_index, out_dir, encoded, nullptr, report, arena,
                          out->records, out);
}

namespace {
// `--blockmaps replace`: the nodes of the levels BlockMaps cover completely
// (replacedLevels) lose their geometry and atlases, written by then (the
// BlockMap rule weighed them); their records list no layer, so
// tileset.json gives them no content, and as their features the BlockMap's
// buildings: every building with a triangle in the node, those the geometry
// had and those it dropped (no geometry is left to have dropped any).
Status omitReplacedNodeFiles(const AtlasTree& tree, std::span<const std::optional<format::BlockMapEntry>> blockmaps,
                             const fs::path& out_dir, std::vector<NodeRecord>& records, NodeBlockMapStats* stats) {
    stats->replaced_levels = replacedLevels(tree, blockmaps);
    for (size_t i = 0; i < tree.nodes.size(); ++i) {
        if (tree.nodes[i].level > stats->replaced_levels) continue;
        for (LayerRecord& l : records[i].layers) {
            if (!l.present) continue;
            for (const std::string& uri : {l.geometry_uri, l.atlas_uri}) {
                std::error_code ec;
                if (!uri.empty() && !fs::remove(out_dir / uri, ec))
                    return Status::Io(fmt::format("{}: cannot remove: {}", (out_dir / uri).string(),
                                                  ec ? ec.message() : "not there"));
            }
            stats->bytes_omitted += l.geometry_bytes + l.atlas_bytes;
            l = LayerRecord{};
        }
        records[i].features = unionOf(records[i].features, records[i].dropped);
        records[i].dropped.clear();
        ++stats->nodes_replaced;
    }
    return Status::Ok();
}
}  // namespace

Status writeTileset(const Scene& scene, const AtlasTree& tree, const fs::path& atlas_dir, const TilesParams& params,
                    const fs::path& out_dir, const std::string& build_hash, Diagnostics& diagnostics,
                    const TilesProgressFn& progress, TilesStats* stats_out, const EncodedAtlases* encoded,
                    BuiltSubtrees* built, const FeatureTables* feature_tables) {
    TilesStats stats;
    const size_t n_nodes = tree.nodes.size();
    if (n_nodes == 0) return Status::Io("tiles: the atlas tree has no nodes");
    const double focal = tree.projection.focal_px;
    const double ppm = tree.projection.pixelsPerMetreAt1m();
    const int A = tree.params.atlas_size_px;
    std::mutex progress_mutex;
    auto report = [&](const char* step, uint64_t done, uint64_t total) {
        if (!progress) return;
        std::lock_guard lock(progress_mutex);
        progress(step, done, total);
    };
    StageClock clock;
    auto endStep = [&](const char* name) {
        const StageCost c = clock.lap();
        stats.steps.push_back({name, c.seconds, c.peak_rss_mb, c.cpu_seconds});
    };
    std::error_code ec;
    // (A sharded build's texture index is lent to the blocks, and given back with the tileset written.)
    TextureBlocks blocks = built ? planTextureBlocks(scene, tree, params.all_originals, params.split_originals,
                                                     std::move(built->texture_index), built->leaf_textures,
                                                     built->leaf_tiles, out_dir)
                                 : planTextureBlocks(scene, tree, params.all_originals, params.split_originals, out_dir);
    std::vector<NodeRecord> records = built ? std::move(built->records) : std::vector<NodeRecord>();
    records.resize(n_nodes);
    tbb::task_arena arena(params.threads > 0 ? params.threads : tbb::task_arena::automatic);

    // --- Node files and the leaves' original textures, side by side: they
    // share nothing but the texture index, and the textures' parallel work
    // fills the cores the geometry's top levels (a few large merges) leave idle.
    Status geometry_status = Status::Ok(), tex_status = Status::Ok();
    arena.execute([&] {
        tbb::task_group side;
        side.run([&] {
            tex_status = writeTextureBlocks(scene, params.bc_quality, out_dir, diagnostics,
                                            [&](uint64_t d, uint64_t t) { report("tiles: textures", d, t); }, &blocks,
                                            built ? built->block_cache : nullptr);
        });
        geometry_status = writeNodeFiles(scene, tree, atlas_dir, params, blocks.texture_index, out_dir, encoded, built,
                                         report, arena, records, nullptr);
        side.wait();
    });
    if (!geometry_status.ok()) return geometry_status;
    if (!tex_status.ok()) return tex_status;
    endStep("geometry, atlases and textures");

    // --- BlockMaps (tiles/node_blockmaps.h), weighed against the node files just written.
    std::vector<std::optional<format::BlockMapEntry>> blockmaps;
    if (params.blockmaps != BlockMapMode::Off) {
        if (built) return Status::Unsupported("tiles: BlockMaps are not built by sharded builds yet");
        std::vector<NodeCost> costs(n_nodes);
        for (size_t i = 0; i < n_nodes; ++i) {
            for (const LayerRecord& l : records[i].layers) costs[i].bytes += l.geometry_bytes + l.atlas_bytes;
            costs[i].dropped = !records[i].dropped.empty();
        }
        Status blockmap_status = Status::Ok();
        arena.execute([&] {
            blockmap_status = writeNodeBlockMaps(
                scene, tree, costs, params.blockmap_levels, params.blockmap_sample, params.bc_quality, static_cast<size_t>(tree.params.cache_mb), out_dir,
                [&](uint64_t d, uint64_t t) { report("tiles: blockmaps", d, t); }, &blockmaps, &stats.blockmaps);
        });
        if (!blockmap_status.ok()) return blockmap_status;
        endStep("blockmaps");
    }
    if (params.blockmaps == BlockMapMode::Replace)
        if (Status st = omitReplacedNodeFiles(tree, blockmaps, out_dir, records, &stats.blockmaps); !st.ok()) return st;

    // --- Feature tables (the caller may have written them already: a
    // sharded build's plan does, and `build` from what its read gathered).
    format::TilesetDocument doc;
    const auto bs = static_cast<size_t>(std::max(1, params.feature_block_size));
    if (!feature_tables && built && built->feature_tables) feature_tables = &*built->feature_tables;
    if (feature_tables) {
        doc.feature_tables = feature_tables->tables;
        doc.feature_bounds = feature_tables->bounds;
        doc.feature_count = feature_tables->features;
    } else {
        FeatureTables ft;
        if (Status w = writeFeatureTables(scene.features, featureBounds(scene), params.feature_block_size, out_dir, &ft);
            !w.ok())
            return w;
        doc.feature_tables = ft.tables;
        doc.feature_bounds = ft.bounds;
        doc.feature_count = ft.features;
    }
    for (const format::FileEntry& f : doc.feature_tables) stats.bytes_features += f.bytes;
    for (const format::FileEntry& f : doc.feature_bounds) stats.bytes_features += f.bytes;
    stats.feature_tables = doc.feature_tables.size();
    doc.feature_block_size = static_cast<int64_t>(bs);

    // --- tileset.json: the document (format/tileset_document.h), tiles in preorder.
    double psnr_sum = 0;
    uint64_t psnr_n = 0, atlas_texels = 0;
    double atlas_seconds = 0;
    stats.atlas_psnr_min_db = std::numeric_limits<double>::infinity();
    std::function<void(int32_t, int32_t, int)> tile = [&](int32_t id, int32_t parent, int quadrant) {
        const AtlasNode& node = tree.nodes[static_cast<size_t>(id)];
        NodeRecord& rec = records[static_cast<size_t>(id)];
        const auto index = static_cast<int32_t>(doc.tiles.size());
        format::TileEntry t;
        t.parent = parent;
        t.id = id;
        t.level = node.level;
        t.quadrant = quadrant;
        t.min_distance_m = node.min_distance_m;
        t.sharp_from_m = node.sharp_from_m;
        t.world_texel_m = node.min_distance_m / ppm;
        t.centre = centreOf(node.bounds);
        const Vec3d h = 0.5 * (node.bounds.max - node.bounds.min);
        t.box = {t.centre.x, t.centre.y, t.centre.z, h.x, 0.0, 0.0, 0.0, h.y, 0.0, 0.0, 0.0, h.z};
        t.geometric_error = node.min_distance_m / focal;
        for (int li = 0; li < atlas::kLayerCount; ++li) {
            const LayerRecord& lr = rec.layers[static_cast<size_t>(li)];
            if (!lr.present) {
                // A layer the geometry step left empty lists no computed textures either.
                if (built && static_cast<size_t>(id) < built->computed_files.size())
                    for (const format::ComputedFileEntry& c : built->computed_files[static_cast<size_t>(id)][static_cast<size_t>(li)])
                        if (!c.file.uri.empty()) {
                            std::error_code ignored;
                            fs::remove(out_dir / c.file.uri, ignored);
                        }
                continue;
            }
            format::LayerEntry le;
            const atlas::NodeLayer& nl = node.layers[static_cast<size_t>(li)];
            if (!lr.atlas_uri.empty()) {
                format::AtlasEntry ae;
                ae.file = {lr.atlas_uri, lr.atlas_bytes};
                ae.format = li == static_cast<int>(Layer::Alpha) ? "BC3" : "BC1";
                ae.width_px = nl.width;
                ae.height_px = nl.height;
                ae.offset = nl.offset;
                ae.mips = lr.atlas_mips;
                // Infinite when BC reproduces the atlas exactly (flat colours): null in
                // the file, and left out of the min and mean.
                ae.psnr_db = std::isfinite(lr.atlas_psnr_db) ? std::round(lr.atlas_psnr_db * 100.0) / 100.0
                                                             : lr.atlas_psnr_db;
                le.atlas = ae;
                ++stats.atlas_files;
                stats.bytes_atlases += lr.atlas_bytes;
                if (std::isfinite(lr.atlas_psnr_db)) {
                    stats.atlas_psnr_min_db = std::min(stats.atlas_psnr_min_db, lr.atlas_psnr_db);
                    psnr_sum += lr.atlas_psnr_db;
                    ++psnr_n;
                } else {
                    ++stats.atlas_files_exact;
                }
                atlas_texels += lr.atlas_texels;
                atlas_seconds += lr.atlas_encode_seconds;
            }
            le.triangles = lr.triangles;
            le.triangles_source = lr.triangles_source;
            le.geometry = {lr.geometry_uri, lr.geometry_bytes};
            le.geometric_error_m = lr.geometric_error_m;
            le.position_error_mm = lr.position_error_m * 1000.0;
            le.position_bits = lr.position_bits;
            le.uv_atlas_error_texels = lr.uv_atlas_error_texels;
            le.simplified = lr.simplified;
            le.left_out_over_cap = lr.left_out_over_cap;
            if (lr.uv_original_error_texels >= 0) {
                le.uv_original_error_texels = lr.uv_original_error_texels;
                le.uv_original_bits = lr.uv_original_bits;
                stats.max_uv_original_error_texels = std::max(stats.max_uv_original_error_texels, lr.uv_original_error_texels);
                stats.uv_original_bits_max = std::max(stats.uv_original_bits_max, lr.uv_original_bits);
            }
            if (built && static_cast<size_t>(id) < built->computed_files.size())
                le.computed = built->computed_files[static_cast<size_t>(id)][static_cast<size_t>(li)];
            t.layers[static_cast<size_t>(li)] = std::move(le);
            t.contents.push_back(lr.geometry_uri);
            t.bytes += lr.geometry_bytes + lr.atlas_bytes;
            ++stats.geometry_files;
            stats.bytes_geometry += lr.geometry_bytes;
            stats.triangles_written += lr.triangles;
            stats.nodes_simplified += lr.simplified ? 1 : 0;
            stats.nodes_capped += lr.left_out_over_cap > 0 ? 1 : 0;
            stats.buildings_left_out_over_cap += lr.left_out_over_cap;
            // A merge capped for memory misses buildings larger than the texel
            // (node_geometry.h), and its error passes up the path: the tile's
            // error covers the layer's (in the texel's units, min_distance /
            // focal = texel * corner factor), so a client refines it where they
            // would show, and a parent's stays at least its child's. Everywhere
            // else a layer's error is below the texel: this changes nothing.
            t.geometric_error = std::max(t.geometric_error, lr.geometric_error_m * ppm / focal);
            stats.max_position_error_m = std::max(stats.max_position_error_m, lr.position_error_m);
            stats.position_bits_min =
                stats.position_bits_min ? std::min(stats.position_bits_min, lr.position_bits) : lr.position_bits;
            stats.position_bits_max = std::max(stats.position_bits_max, lr.position_bits);
            stats.max_geometric_error_m = std::max(stats.max_geometric_error_m, lr.geometric_error_m);
            const double texel = node.min_distance_m / ppm;
            if (texel > 0)
                stats.max_geometric_error_fraction =
                    std::max(stats.max_geometric_error_fraction, lr.geometric_error_m / texel);
            stats.max_uv_atlas_error_texels = std::max(stats.max_uv_atlas_error_texels, lr.uv_atlas_error_texels);
        }
        for (uint32_t f : rec.features) {
            const auto table = static_cast<uint32_t>(f / bs);
            if (t.feature_tables.empty() || t.feature_tables.back() != table) t.feature_tables.push_back(table);
        }
        // The record's lists are not needed after this: moved or freed (a city's are tens of MB).
        t.feature_count = rec.features.size();
        std::vector<uint32_t>().swap(rec.features);
        t.features_dropped = std::move(rec.dropped);
        for (const uint32_t b : blocks.node_blocks[static_cast<size_t>(id)]) t.texture_blocks.push_back(b);
        if (!blockmaps.empty()) t.blockmap = std::move(blockmaps[static_cast<size_t>(id)]);
        doc.tiles.push_back(std::move(t));
        for (size_t q = 0; q < 4; ++q)
            if (node.children[q] >= 0) {
                doc.tiles[static_cast<size_t>(index)].children.push_back(static_cast<int32_t>(doc.tiles.size()));
                tile(node.children[q], index, static_cast<int>(q));
            }
        ++stats.nodes;
        stats.leaves += node.leaf() ? 1 : 0;
        stats.depth = std::max<uint64_t>(stats.depth, static_cast<uint64_t>(node.level));
    };
    tile(0, -1, -1);
    doc.tiles[0].transform = scene.georef.local_to_ecef;
    stats.root_features = doc.tiles[0].feature_count;
    stats.root_features_dropped = doc.tiles[0].features_dropped;
    stats.atlas_psnr_mean_db = psnr_n ? psnr_sum / static_cast<double>(psnr_n) : 0;
    if (!psnr_n) stats.atlas_psnr_min_db = 0;
    stats.atlas_encode_mpix_per_s = atlas_seconds > 0 ? static_cast<double>(atlas_texels) / 1e6 / atlas_seconds : 0;

    for (const Material& m : scene.materials)
        doc.materials.push_back({{m.diffuse[0], m.diffuse[1], m.diffuse[2]}, m.transparency});
    // The texture entries, read back in tileset order: once for the totals, once as they are written.
    for (size_t i = 0; i < blocks.size(); ++i) {
        const TextureEntry e = blocks.entry(scene.textures, i);
        if (e.block >= 0) ++stats.textures_written;
        else if (e.exact) ++stats.textures_exact;
        else ++stats.textures_unreadable;
        stats.bytes_originals_bc += atlas::bcBytesWithMips(std::max(e.width, 1), std::max(e.height, 1), e.channels);
    }
    if (!blocks.written.status().ok()) return blocks.written.status();
    doc.texture_count = blocks.size();
    doc.texture_at = [&](size_t i) -> format::TextureEntry {
        const TextureEntry e = blocks.entry(scene.textures, i);
        return {e.block, e.offset, e.bytes, std::max(e.width, 1), std::max(e.height, 1),
                e.channels == 4 ? "BC3" : "BC1", std::max<int>(e.mips, 1), std::string(wrapModeName(e.wrap)),
                e.block >= 0 ? "written" : e.exact ? "exact" : "unreadable"};
    };
    for (size_t b = 0; b < blocks.block_bytes.size(); ++b) {
        doc.texture_blocks.push_back({fmt::format("textures/{}.bin", b), blocks.block_bytes[b]});
        stats.bytes_textures += blocks.block_bytes[b];
    }
    stats.texture_blocks = blocks.block_bytes.size();

    const Georeference& g = scene.georef;
    doc.georeference = {g.source_crs, g.origin_source, g.grid_frame, g.local_to_ecef, g.enu_to_ecef};
    const atlas::AtlasParams& ap = tree.params;
    format::BuildEntry& b = doc.build;
    b.d_min_m = tree.stats.d_min_used_m;
    b.d_min_requested_m = tree.stats.d_min_requested_m;
    b.atlas_size_px = A;
    b.border_px = ap.border_px;
    b.tau = 1.0;
    b.screen_width_px = ap.screen_width_px;
    b.screen_height_px = ap.screen_height_px;
    b.vertical_fov_deg = ap.vertical_fov_deg;
    b.focal_px = focal;
    b.corner_factor = tree.projection.corner_factor;
    b.filter = atlas::filterName(ap.filter);
    b.packing = atlas::packingMethodName(ap.packing);
    b.unique_charts = ap.unique_charts;
    b.position_bits = params.draco.position_bits;
    b.position_error_target_mm = params.position_error_target_m * 1000.0;
    b.uv_bits = params.draco.uv_bits;
    b.bc_quality = bcQualityName(params.bc_quality);
    b.originals = params.all_originals ? "all" : "needed";
    b.d_min_chosen_by = tree.stats.d_min_choice.rule;
    b.node_triangles = params.node_triangles;
    stats.merge_triangles_max = mergeMaxTriangles(params.node_triangles);
    b.geometry_encoder =
        fmt::format("Draco {} (KHR_draco_mesh_compression, speed {})", draco::kDracoVersion, params.draco.speed);
    b.texture_encoder = params.bc_quality == BcQuality::Fast ? "stb_dxt (STB_DXT_HIGHQUAL)" : "libsquish (cluster fit)";
    if (built) {
        doc.computed = built->computed;
        for (format::ComputedTextureEntry& c : doc.computed) c.bytes = 0;
        for (const format::TileEntry& t : doc.tiles)
            for (const auto& layer : t.layers)
                if (layer)
                    for (size_t k = 0; k < layer->computed.size() && k < doc.computed.size(); ++k)
                        doc.computed[k].bytes += layer->computed[k].file.bytes;
    }
    doc.totals = {stats.nodes,          stats.leaves,        stats.depth,
                  stats.bytes_geometry, stats.bytes_atlases, stats.bytes_textures,
                  stats.bytes_features, stats.bytes_originals_bc, textureRatio(stats)};
    doc.totals.bytes_blockmaps = stats.blockmaps.bytes;
    doc.build.blockmaps = std::string(blockMapModeName(params.blockmaps));
    doc.generator = fmt::format("cityatlas {}", kCityAtlasVersion);
    doc.tileset_version = build_hash;
    doc.geometric_error = std::max(2.0 * tree.nodes[0].min_distance_m / focal, doc.tiles[0].geometric_error);
    {
        // Written as it is made: at a million buildings the text is ~300 MB.
        const fs::path path = out_dir / "tileset.json";
        std::ofstream f(path, std::ios::binary);
        if (!f) return Status::Io(fmt::format("{}: cannot create: {}", path.string(), std::strerror(errno)));
        format::writeTilesetDocument(doc, f);
        f.close();
        if (!blocks.written.status().ok()) return blocks.written.status();
        if (!f) return Status::Io(fmt::format("{}: cannot write (disk full?)", path.string()));
        std::error_code ec;
        stats.bytes_tileset = fs::file_size(path, ec);
        if (ec) return Status::Io(fmt::format("{}: {}", path.string(), ec.message()));
    }
    endStep("index");
    if (stats_out) *stats_out = std::move(stats);
    if (built) built->texture_index = std::move(blocks.texture_index);
    return Status::Ok();
}

}  // namespace cityatlas::tiles
