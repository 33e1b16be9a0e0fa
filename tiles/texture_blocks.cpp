// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/texture_blocks.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <deque>
#include <memory>
#include <mutex>
#include <numeric>
#include <set>
#include <span>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <OpenImageIO/imageio.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

namespace cityatlas::tiles {
namespace fs = std::filesystem;

bool readImage8(const std::string& path, int channels, Image8* out, std::string* why) {
    OIIO::ImageSpec config;
    config.attribute("oiio:UnassociatedAlpha", 1);
    auto in = OIIO::ImageInput::open(path, &config);
    if (!in) {
        *why = OIIO::geterror();
        if (why->empty()) *why = "cannot open";
        return false;
    }
    const OIIO::ImageSpec spec = in->spec();
    const int nc = spec.nchannels;
    if (spec.width < 1 || spec.height < 1 || nc < 1) {
        *why = "empty image";
        return false;
    }
    // Row by row: OpenImageIO 2.4's multi-row read_image/read_scanlines of a PNG
    // decodes through a fresh buffer each call, and first-touch page faults made
    // it 2.5x slower (500 reads of a 512^2 RGB PNG: 2.03 s, 109 k faults;
    // per row: 0.80 s, 13 k faults).
    std::vector<uint8_t> raw(static_cast<size_t>(spec.width) * spec.height * nc);
    // Tiled files (TIFF) read whole.
    const size_t row_bytes = static_cast<size_t>(spec.width) * nc;
    bool read = true;
    if (spec.tile_width > 0)
        read = in->read_image(0, 0, 0, nc, OIIO::TypeDesc::UINT8, raw.data());
    else
        for (int y = 0; y < spec.height && read; ++y)
            read = in->read_scanline(spec.y + y, spec.z, OIIO::TypeDesc::UINT8, &raw[static_cast<size_t>(y) * row_bytes]);
    if (!read) {
        *why = in->geterror();
        if (why->empty()) *why = "cannot decode";
        return false;
    }
    Image8 img;
    img.width = spec.width;
    img.height = spec.height;
    img.channels = channels;
    img.pixels.resize(static_cast<size_t>(img.width) * img.height * channels);
    const size_t n = static_cast<size_t>(img.width) * img.height;
    for (size_t i = 0; i < n; ++i) {
        const uint8_t* s = &raw[i * nc];
        uint8_t* d = &img.pixels[i * channels];
        const bool grey = nc < 3;
        d[0] = s[0];
        d[1] = grey ? s[0] : s[1];
        d[2] = grey ? s[0] : s[2];
        if (channels == 4) d[3] = nc == 2 ? s[1] : nc >= 4 ? s[3] : 255;
    }
    *out = std::move(img);
    return true;
}

TextureIndex tilesetTextureIndex(const std::vector<uint8_t>& used, const TextureTable& textures, int atlas_size_px,
                                 bool split, const fs::path& scratch_dir) {
    TextureIndex index = makeTextureIndex(scratch_dir);
    int32_t next = 0;
    for (size_t t = 0; t < used.size(); ++t) {
        if (!used[t]) {
            index.push_back(-1);
            continue;
        }
        index.push_back(next);
        next += 1 + splitGridOf(textures[t], atlas_size_px, split).count();  // the whole texture, then its tiles
    }
    return index;
}

std::vector<std::vector<int32_t>> leafTiles(const Scene& scene, const atlas::AtlasTree& tree,
                                            const TextureIndex& texture_index, bool split) {
    std::vector<std::vector<int32_t>> out(tree.nodes.size());
    std::vector<TilePiece> pieces;
    for (size_t ni = 0; ni < tree.nodes.size(); ++ni) {
        const atlas::AtlasNode& node = tree.nodes[ni];
        if (!node.leaf()) continue;
        for (const atlas::NodeLayer& layer : node.layers)
            for (uint32_t i = layer.range.first; i < layer.range.first + layer.range.count; ++i) {
                const Triangle& t = tree.triangles[i].tri;
                if (t.texture < 0) continue;
                const TileGrid grid = splitGridOf(scene.textures[static_cast<size_t>(t.texture)], tree.params.atlas_size_px, split);
                if (grid.count() == 0) continue;
                pieces.clear();
                const int32_t first = texture_index[static_cast<size_t>(t.texture)];
                if (!clipToTiles(grid, {ClipVertex{t.position_local[0], t.uv[0], {}}, ClipVertex{t.position_local[1], t.uv[1], {}},
                                        ClipVertex{t.position_local[2], t.uv[2], {}}},
                                 &pieces))
                    out[ni].push_back(first);  // repeated over two periods: the whole texture
                for (const TilePiece& p : pieces) out[ni].push_back(first + 1 + p.tile);
            }
        std::sort(out[ni].begin(), out[ni].end());
        out[ni].erase(std::unique(out[ni].begin(), out[ni].end()), out[ni].end());
    }
    return out;
}

std::vector<std::vector<int32_t>> leafTextures(const atlas::AtlasTree& tree) {
    std::vector<std::vector<int32_t>> used(tree.nodes.size());
    for (size_t ni = 0; ni < tree.nodes.size(); ++ni) {
        const atlas::AtlasNode& node = tree.nodes[ni];
        if (!node.leaf()) continue;
        for (const atlas::NodeLayer& layer : node.layers)
            for (uint32_t i = layer.range.first; i < layer.range.first + layer.range.count; ++i)
                if (const int32_t st = tree.triangles[i].tri.texture; st >= 0) used[ni].push_back(st);
        std::sort(used[ni].begin(), used[ni].end());
        used[ni].erase(std::unique(used[ni].begin(), used[ni].end()), used[ni].end());
    }
    return used;
}

TextureBlocks planTextureBlocks(const Scene& scene, const atlas::AtlasTree& tree, bool all, bool split,
                                const fs::path& scratch_dir) {
    std::vector<uint8_t> used(scene.textures.size(), 0);
    for (const atlas::TreeTriangle& t : tree.triangles)
        if (t.tri.texture >= 0) used[static_cast<size_t>(t.tri.texture)] = 1;
    TextureIndex index = tilesetTextureIndex(used, scene.textures, tree.params.atlas_size_px, split, scratch_dir);
    std::vector<std::vector<int32_t>> tiles = leafTiles(scene, tree, index, split);
    return planTextureBlocks(scene, tree, all, split, std::move(index), leafTextures(tree), tiles, scratch_dir);
}

TextureEntry TextureBlocks::planned(const TextureTable& textures, size_t t) const {
    const auto st = static_cast<size_t>(scene_texture[t]);
    const TextureInfo& ref = textures[st];
    TextureEntry e;
    e.scene_texture = scene_texture[t];
    e.width = ref.width_px;
    e.height = ref.height_px;
    e.channels = ref.channels == 4 ? 4 : 3;
    e.wrap = ref.wrap;
    e.block = std::max(block[t], -1);
    e.exact = block[t] == kExact;
    if (const auto k = static_cast<int32_t>(t) - texture_index[st]; k > 0) {
        // A tile is sampled clamped: its overlap holds what lies beyond its core.
        e.tile = k - 1;
        e.tile_rect = tilesetEntries(ref, atlas_size_px, split).at(static_cast<size_t>(k));
        e.width = e.tile_rect.width(), e.height = e.tile_rect.height();
        e.wrap = WrapMode::Clamp;
    }
    return e;
}

TextureEntry TextureBlocks::entry(const TextureTable& textures, size_t t) {
    TextureEntry e = planned(textures, t);
    if (e.block < 0) return e;
    const WrittenTexture w = written.get(t);
    if (!written.status().ok()) return e;
    e.offset = w.offset, e.bytes = w.bytes;
    e.width = w.width, e.height = w.height;  // the real size wins over the one recorded at ingest
    e.mips = static_cast<uint8_t>(w.mips);
    return e;
}

TextureBlocks planTextureBlocks(const Scene& scene, const atlas::AtlasTree& tree, bool all, bool split,
                                TextureIndex texture_index,
                                const std::vector<std::vector<int32_t>>& leaf_textures,
                                const std::vector<std::vector<int32_t>>& leaf_tiles, const fs::path& scratch_dir) {
    TextureBlocks b;
    b.texture_index = std::move(texture_index);
    b.atlas_size_px = tree.params.atlas_size_px;
    b.split = split;
    b.written = RecordFile<WrittenTexture>(scratch_dir, "the written textures' entries");
    b.node_blocks.resize(tree.nodes.size());
    b.node_textures = PagedColumn<int32_t>(scratch_dir, "the leaves' needed originals", TextureBlocks::columnBytes());
    b.node_texture_first.assign(tree.nodes.size() + 1, 0);
    const uint64_t block_texels = static_cast<uint64_t>(tree.params.atlas_size_px) * tree.params.atlas_size_px;
    uint64_t current_texels = 0;
    int32_t current = -1;
    // Every used texture has its entries (the leaves' geometry names them by
    // their rank among the used ones); exact until some leaf needs its original.
    size_t entries = 0;
    for (size_t st = b.texture_index.size(); st-- > 0;)
        if (b.texture_index[st] >= 0) {
            entries = static_cast<size_t>(b.texture_index[st]) + 1 +
                      splitGridOf(scene.textures[st], tree.params.atlas_size_px, split).count();
            break;
        }
    // Tileset numbers ascend with scene textures: each used one's entries in turn.
    b.scene_texture = PagedColumn<int32_t>(scratch_dir, "the tileset textures' scene textures", TextureBlocks::columnBytes());
    b.block = PagedColumn<int32_t>(scratch_dir, "the tileset textures' blocks", TextureBlocks::columnBytes());
    for (size_t st = 0; st < b.texture_index.size(); ++st) {
        const int32_t ti = b.texture_index[st];
        if (ti < 0) continue;
        const int tiles = splitGridOf(scene.textures[st], tree.params.atlas_size_px, split).count();
        while (b.scene_texture.size() < static_cast<size_t>(ti)) b.scene_texture.push_back(-1);  // no gaps: a guard
        for (int k = 0; k <= tiles; ++k) b.scene_texture.push_back(static_cast<int32_t>(st));
    }
    while (b.scene_texture.size() < entries) b.scene_texture.push_back(-1);
    for (size_t t = 0; t < entries; ++t) b.block.push_back(TextureBlocks::kExact);
    // Nodes are in depth-first preorder, so leaves come in depth-first order:
    // a block holds the originals of neighbouring leaves.
    for (size_t ni = 0; ni < tree.nodes.size(); ++ni) {
        const atlas::AtlasNode& node = tree.nodes[ni];
        b.node_texture_first[ni + 1] = b.node_texture_first[ni];
        if (!node.leaf()) continue;
        std::vector<uint32_t>& mine = b.node_blocks[ni];
        // The tileset textures this leaf needs: the whole texture, or the
        // tiles of a split one that its triangles use.
        std::vector<int32_t> needed;
        for (const int32_t st : all ? leaf_textures[ni] : node.originals) {
            const int32_t ti = b.texture_index[static_cast<size_t>(st)];
            if (ti < 0) continue;
            const int tiles = splitGridOf(scene.textures[static_cast<size_t>(st)], tree.params.atlas_size_px, split).count();
            if (tiles == 0) {
                needed.push_back(ti);
                continue;
            }
            if (ni < leaf_tiles.size())
                for (const int32_t t : leaf_tiles[ni])
                    if (t >= ti && t <= ti + tiles) needed.push_back(t);
        }
        for (const int32_t ti : needed) {
            int32_t blk = b.block[static_cast<size_t>(ti)];
            if (blk == TextureBlocks::kExact) {
                const TextureEntry e = b.planned(scene.textures, static_cast<size_t>(ti));
                const uint64_t texels = static_cast<uint64_t>(std::max(e.width, 1)) * std::max(e.height, 1);
                if (texels >= block_texels) {
                    blk = static_cast<int32_t>(b.block_bytes.size());  // a block of its own
                    b.block_bytes.push_back(0);
                } else {
                    if (current < 0 || current_texels + texels > block_texels) {
                        current = static_cast<int32_t>(b.block_bytes.size());
                        b.block_bytes.push_back(0);
                        current_texels = 0;
                    }
                    current_texels += texels;
                    blk = current;
                }
                b.block.set(static_cast<size_t>(ti), blk);
            }
            const auto ub = static_cast<uint32_t>(blk);
            if (std::find(mine.begin(), mine.end(), ub) == mine.end()) mine.push_back(ub);
            b.node_textures.push_back(ti);
        }
        b.node_texture_first[ni + 1] = b.node_textures.size();
        std::sort(mine.begin(), mine.end());
    }
    return b;
}

namespace {

// The decoded images of split textures, so their tiles are cut from one
// decode instead of one per tile: the two last used are kept (an orthophoto's
// tiles come leaf by leaf, interleaved with other textures). Decoding holds
// the lock, so two tiles of one image never decode it twice.
class SplitSources {
public:
    std::shared_ptr<const Image8> get(const TextureEntry& e, const TextureRef& ref, std::string* why) {
        std::lock_guard<std::mutex> lock(mutex_);
        for (const auto& [texture, image] : kept_)
            if (texture == e.scene_texture) return image;
        auto image = std::make_shared<Image8>();
        if (!readImage8(ref.path, e.channels, image.get(), why)) {
            if (why->empty()) *why = "unreadable";
            return nullptr;
        }
        if (kept_.size() == 2) kept_.pop_front();
        kept_.emplace_back(e.scene_texture, image);
        return image;
    }

private:
    std::mutex mutex_;
    std::deque<std::pair<int32_t, std::shared_ptr<const Image8>>> kept_;
};

}  // namespace

Status writeTextureBlocks(const Scene& scene, BcQuality quality, const fs::path& out_dir, Diagnostics& diagnostics,
                          const std::function<void(uint64_t, uint64_t)>& progress, TextureBlocks* blocks,
                          BlockCache* cache) {
    std::error_code ec;
    fs::create_directories(out_dir / "textures", ec);
    if (ec) return Status::Io(fmt::format("{}: cannot create: {}", (out_dir / "textures").string(), ec.message()));
    const size_t nblocks = blocks->block_bytes.size();
    // Each block's textures (tileset numbers, ascending): one list cut by block, 4 bytes a written texture.
    std::vector<uint64_t> first_member(nblocks + 1, 0);
    uint64_t exact = 0;
    for (size_t t = 0; t < blocks->size(); ++t) {
        const int32_t blk = blocks->block[t];
        if (blk >= 0) ++first_member[static_cast<size_t>(blk) + 1];
        exact += blk == TextureBlocks::kExact;
    }
    std::partial_sum(first_member.begin(), first_member.end(), first_member.begin());
    std::vector<uint32_t> member_list(first_member.back());
    {
        std::vector<uint64_t> at(first_member.begin(), first_member.end() - 1);
        for (size_t t = 0; t < blocks->size(); ++t)
            if (const int32_t blk = blocks->block[t]; blk >= 0) member_list[at[static_cast<size_t>(blk)]++] = static_cast<uint32_t>(t);
    }
    const auto members = [&](size_t blk) {
        return std::span<const uint32_t>(member_list.data() + first_member[blk], first_member[blk + 1] - first_member[blk]);
    };

    struct Encoded {
        std::vector<uint8_t> dds;
        std::string why;  // non-empty: unreadable
        int mips = 0;
        uint64_t texels = 0;
        double seconds = 0;
        int width = 0, height = 0;
        uint64_t bytes = 0;  // a cached block's: its DDS size (dds stays empty)
    };
    std::vector<std::string> keys(nblocks);
    if (cache && cache->key) {
        std::error_code mk;
        fs::create_directories(cache->to, mk);
        if (mk) return Status::Io(fmt::format("{}: cannot create: {}", cache->to.string(), mk.message()));
        for (size_t blk = 0; blk < nblocks; ++blk) {
            std::vector<TextureEntry> textures;
            for (const uint32_t t : members(blk)) textures.push_back(blocks->planned(scene.textures, t));
            keys[blk] = cache->key(textures);
        }
    }
    // A cached block's textures as its metadata file lists them; false when there is none.
    auto cached = [&](size_t blk, std::vector<Encoded>* enc) {
        if (keys[blk].empty() || cache->from.empty()) return false;
        std::ifstream meta(cache->from / (keys[blk] + ".json"));
        if (!meta || !fs::exists(cache->from / (keys[blk] + ".bin"))) return false;
        try {
            const nlohmann::json j = nlohmann::json::parse(meta);
            if (j.size() != members(blk).size()) return false;
            enc->assign(j.size(), {});
            for (size_t k = 0; k < j.size(); ++k) {
                Encoded& e = (*enc)[k];
                e.bytes = j[k].at("bytes"), e.mips = j[k].at("mips"), e.texels = j[k].at("texels");
                e.width = j[k].at("width"), e.height = j[k].at("height");
            }
        } catch (const std::exception&) {
            return false;
        }
        return true;
    };
    SplitSources split_sources;
    // Encodes one block's textures (in parallel: a block may hold a single large original).
    auto encodeBlock = [&](size_t blk) {
        const std::span<const uint32_t> list = members(blk);
        std::vector<Encoded> enc(list.size());
        if (cached(blk, &enc)) return enc;
        tbb::parallel_for(size_t{0}, list.size(), [&](size_t k) {
            const TextureEntry e = blocks->planned(scene.textures, list[k]);
            const TextureRef ref = scene.textures.ref(static_cast<size_t>(e.scene_texture));
            Image8 img;
            // Straight alpha, as the client blends (GL_SRC_ALPHA): OpenImageIO
            // premultiplies many RGBA PNGs on read, which drew translucent
            // glass at street level with alpha squared.
            if (e.tile >= 0) {
                const std::shared_ptr<const Image8> whole = split_sources.get(e, ref, &enc[k].why);
                if (!whole) return;
                img = cropTile(*whole, e.tile_rect, ref.wrap == WrapMode::Wrap);
            } else if (!readImage8(ref.path, e.channels, &img, &enc[k].why)) {
                if (enc[k].why.empty()) enc[k].why = "unreadable";
                return;
            }
            const auto t0 = std::chrono::steady_clock::now();
            const std::vector<Image8> mips = mipChain(img);
            for (const Image8& m : mips) enc[k].texels += static_cast<uint64_t>(m.width) * m.height;
            enc[k].dds = encodeDds(mips, quality);
            enc[k].mips = static_cast<int>(mips.size());
            enc[k].seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            enc[k].width = img.width, enc[k].height = img.height;
        });
        return enc;
    };
    uint64_t done = 0;
    // A block whose textures are all unreadable is not written; the others are
    // renumbered densely so every block in the index has a file of >= 1 byte.
    // Writes one encoded block, in block order (the numbering and the bytes do not
    // depend on the thread count).
    std::vector<uint64_t> written_bytes;
    std::set<int32_t> warned_split;
    Status write_status = Status::Ok();
    auto writeBlock = [&](size_t blk, std::vector<Encoded>& enc) {
        const std::span<const uint32_t> list = members(blk);
        const bool any_readable = std::any_of(enc.begin(), enc.end(), [](const Encoded& x) { return x.why.empty(); });
        const bool all_readable = std::all_of(enc.begin(), enc.end(), [](const Encoded& x) { return x.why.empty(); });
        const bool reused = !enc.empty() && enc.front().dds.empty() && enc.front().bytes > 0;
        const auto index = static_cast<int32_t>(written_bytes.size());
        const fs::path path = out_dir / "textures" / fmt::format("{}.bin", index);
        std::ofstream f;
        if (reused) {
            // Linked, not written: the previous build's block of the same content.
            std::error_code le;
            fs::create_hard_link(cache->from / (keys[blk] + ".bin"), path, le);
            if (le) fs::copy_file(cache->from / (keys[blk] + ".bin"), path, fs::copy_options::overwrite_existing, le);
            if (le) {
                write_status = Status::Io(fmt::format("{}: cannot reuse the cached block: {}", path.string(), le.message()));
                return;
            }
            ++cache->reused;
        } else if (any_readable) {
            f.open(path, std::ios::binary);
        }
        uint64_t offset = 0;
        std::vector<WrittenTexture> written(list.size());
        for (size_t k = 0; k < list.size(); ++k) {
            if (!enc[k].why.empty()) {
                blocks->block.set(list[k], TextureBlocks::kUnreadable);
                const TextureEntry e = blocks->planned(scene.textures, list[k]);
                if (e.tile >= 0 && !warned_split.insert(e.scene_texture).second) continue;  // once per texture, not per tile
                diagnostics.warn(warn::kTextureUnreadable,
                                 {scene.textures.path(static_cast<size_t>(e.scene_texture)), 0, "",
                                  "original texture for near views not written (leaves draw their atlas): " + enc[k].why});
                continue;
            }
            blocks->block.set(list[k], index);
            WrittenTexture& w = written[k];
            // The real size wins over the one recorded at ingest.
            w.width = enc[k].width, w.height = enc[k].height;
            if (!reused)
                f.write(reinterpret_cast<const char*>(enc[k].dds.data()), static_cast<std::streamsize>(enc[k].dds.size()));
            w.offset = offset;
            w.bytes = reused ? enc[k].bytes : enc[k].dds.size();
            w.mips = enc[k].mips;
            offset += w.bytes;
            blocks->texels_encoded += enc[k].texels;
            blocks->encode_seconds += enc[k].seconds;
        }
        // Kept by tileset number, a run of consecutive numbers at a time.
        for (size_t k = 0, run = 0; k < list.size(); k = run) {
            for (run = k + 1; run < list.size() && list[run] == list[run - 1] + 1;) ++run;
            if (Status s = blocks->written.write(list[k], &written[k], run - k); !s.ok()) {
                write_status = s;
                return;
            }
        }
        done += list.size();
        if (progress) progress(done, blocks->size() - exact);
        if (!any_readable) return;
        if (!reused) {
            f.close();
            if (!f) {
                write_status = Status::Io(fmt::format("{}: cannot write: {}", path.string(), std::strerror(errno)));
                return;
            }
            if (cache) ++cache->encoded;
        }
        written_bytes.push_back(offset);
        // Kept for the next build: the block (a hard link) and what it holds.
        if (cache && !keys[blk].empty() && all_readable) {
            std::error_code ke;
            const fs::path bin = cache->to / (keys[blk] + ".bin");
            fs::remove(bin, ke);
            fs::create_hard_link(path, bin, ke);
            if (ke) fs::copy_file(path, bin, fs::copy_options::overwrite_existing, ke);
            nlohmann::json meta = nlohmann::json::array();
            for (size_t k = 0; k < list.size(); ++k) {
                const WrittenTexture& w = written[k];
                meta.push_back({{"bytes", w.bytes}, {"mips", w.mips}, {"texels", enc[k].texels}, {"width", w.width},
                                {"height", w.height}});
            }
            std::ofstream m(cache->to / (keys[blk] + ".json"));
            m << meta.dump();
            if (ke || !m) write_status = Status::Io(fmt::format("{}: cannot keep the block for the next build", bin.string()));
        }
    };
    // A pipeline rather than block after block: every core encodes while the
    // blocks are written in order, and at most a few blocks' DDS bytes are held
    // at once (memory bounded by the token count, whatever the city's texture total).
    const size_t tokens = 2 * static_cast<size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
    size_t next = 0;
    tbb::parallel_pipeline(
        tokens,
        tbb::make_filter<void, size_t>(tbb::filter_mode::serial_in_order,
                                       [&](tbb::flow_control& fc) -> size_t {
                                           if (next >= nblocks || !write_status.ok()) {
                                               fc.stop();
                                               return 0;
                                           }
                                           return next++;
                                       }) &
            tbb::make_filter<size_t, std::pair<size_t, std::vector<Encoded>>>(
                tbb::filter_mode::parallel, [&](size_t blk) { return std::pair{blk, encodeBlock(blk)}; }) &
            tbb::make_filter<std::pair<size_t, std::vector<Encoded>>, void>(
                tbb::filter_mode::serial_in_order, [&](std::pair<size_t, std::vector<Encoded>> b) {
                    if (write_status.ok()) writeBlock(b.first, b.second);
                }));
    if (!write_status.ok()) return write_status;
    blocks->block_bytes = std::move(written_bytes);
    // A leaf lists the blocks its needed originals ended up in: a texture that
    // could not be read leaves no block behind, even when its block survives
    // for another leaf's texture.
    for (size_t n = 0; n < blocks->node_blocks.size(); ++n) {
        std::vector<uint32_t> kept;
        for (uint64_t k = blocks->node_texture_first[n]; k < blocks->node_texture_first[n + 1]; ++k)
            if (const int32_t blk = blocks->block[static_cast<size_t>(blocks->node_textures[k])]; blk >= 0)
                kept.push_back(static_cast<uint32_t>(blk));
        std::sort(kept.begin(), kept.end());
        kept.erase(std::unique(kept.begin(), kept.end()), kept.end());
        blocks->node_blocks[n] = std::move(kept);
    }
    return Status::Ok();
}

}  // namespace cityatlas::tiles
