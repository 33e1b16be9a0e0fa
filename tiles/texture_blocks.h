// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Leaves' original textures, for drawing closer than a leaf's min distance
/// (papers/000 §4.6): each used texture as a DDS (BC1 / BC3, full mip chain),
/// grouped into block files of roughly one atlas of texels so a client loads
/// a neighbourhood's textures in a few requests. Textures are taken in the
/// order leaves first use them (depth-first), so a block holds textures of
/// neighbouring leaves; a texture larger than one atlas is a block of its own.
///
/// A texture of more than two atlases of texels is split (with `split`;
/// tiles/texture_tiles.h): it takes consecutive tileset numbers,
/// the whole texture first, then each of its overlapping tiles; the leaves'
/// triangles are cut at the tile lines and name their tiles (a triangle
/// repeating the texture over two periods or more names the whole texture),
/// and a leaf needs only what its triangles name (an orthophoto on every
/// roof: each leaf the tiles under its roofs).

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "atlas/atlas_tree.h"
#include "core/paged_column.h"
#include "core/record_file.h"
#include "core/status.h"
#include "ingest/diagnostics.h"
#include "ingest/scene.h"
#include "tiles/texture_codec.h"
#include "tiles/texture_index.h"
#include "tiles/texture_tiles.h"

namespace cityatlas::tiles {

// A used texture (or tile) of the whole city, as tileset.json lists it.
// The merge no longer holds one a texture (56 bytes each, a tenth of a
// kilobyte with the rest at 10 million textures): TextureBlocks keeps 12
// bytes a texture and makes an entry on request.
struct TextureEntry {
    int32_t scene_texture = -1;
    int32_t tile = -1;                ///< a split texture's tile (texture_tiles.h); -1: the whole texture
    TexelRect tile_rect;              ///< the tile's texels in the scene texture
    int32_t block = -1;               ///< -1: not written (exact, or unreadable)
    int width = 0, height = 0;
    uint8_t channels = 0, mips = 0;
    WrapMode wrap = WrapMode::Wrap;
    bool exact = false;               ///< the atlases hold it at full resolution: no original is written
    uint64_t offset = 0, bytes = 0;   ///< the DDS inside its block
};

/// What a texture's encoding gave: its place in its block, its real size
/// and mip count. One a written texture, kept in a scratch file by tileset
/// number (read back in order for tileset.json).
struct WrittenTexture {
    uint64_t offset = 0, bytes = 0;
    int32_t width = 0, height = 0;
    int32_t mips = 0;
    int32_t pad = 0;  ///< 32 bytes, no uninitialised bytes written to the file
};

struct TextureBlocks {
    static constexpr int32_t kExact = -1;       ///< block: no leaf needs its original
    static constexpr int32_t kUnreadable = -2;  ///< block: needed, but its file could not be read
    /// Each column's memory: a quarter of the texture table's (16 MiB).
    static size_t columnBytes() { return TextureTable::defaultMemoryBytes() / 4; }

    TextureIndex texture_index;               ///< scene texture -> (first) tileset texture, -1 unused
    /// Per tileset texture (tileset order): its scene texture, and its block
    /// (kExact or kUnreadable). Columns that stop growing at columnBytes()
    /// (core/paged_column.h: a city's pages beyond go to a scratch file).
    PagedColumn<int32_t> scene_texture{{}, "the tileset textures' scene textures", columnBytes()};
    PagedColumn<int32_t> block{{}, "the tileset textures' blocks", columnBytes()};
    int atlas_size_px = 0;                    ///< with `split`, what cuts a split texture's tiles
    bool split = false;
    std::vector<uint64_t> block_bytes;        ///< per block; the file is textures/<block>.bin
    std::vector<std::vector<uint32_t>> node_blocks;  ///< per node (leaves only), ascending
    /// The tileset textures each leaf needs originals of, leaf after leaf
    /// (node n's: node_texture_first[n] .. node_texture_first[n + 1] - 1): a
    /// column, as they are written and read in node order (4 bytes a needed
    /// texture, past columnBytes() in a scratch file; until stop 55 a
    /// vector per node).
    PagedColumn<int32_t> node_textures{{}, "the leaves' needed originals", columnBytes()};
    std::vector<uint64_t> node_texture_first;  ///< per node, and one past the last
    uint64_t texels_encoded = 0;              ///< all mip levels
    double encode_seconds = 0;                ///< summed over threads
    RecordFile<WrittenTexture> written;       ///< by tileset number (writeTextureBlocks)

    size_t size() const { return block.size(); }
    /// Tileset texture `t` as planned: its scene texture, tile, size
    /// recorded at ingest, channels, wrap; block and exact as they stand.
    /// Without what writing it gave (offset, bytes, mips): entry().
    TextureEntry planned(const TextureTable& textures, size_t t) const;
    /// Tileset texture `t` whole, once its block is written: what writing it
    /// gave read back (fast in tileset order, correct in any). A failed read
    /// back (written.status()) gives the planned entry.
    TextureEntry entry(const TextureTable& textures, size_t t);
};

/// Plans the blocks from the texture sizes recorded at ingest (nothing is
/// decoded). Each leaf gets the originals it needs (AtlasNode::originals), or
/// with `all` every texture it uses; every used texture has an entry (a
/// split one an entry per tile), in scene order (tilesetTextureIndex); those
/// no leaf needs are marked exact (no block). `scratch_dir`: where the
/// written entries will wait (empty: the system's temporary folder).
TextureBlocks planTextureBlocks(const Scene& scene, const atlas::AtlasTree& tree, bool all = false, bool split = false,
                                const std::filesystem::path& scratch_dir = {});

/// The same for a tree without its triangles (a sharded build's merge):
/// `texture_index` (scene texture -> first tileset texture, -1 unused;
/// tilesetTextureIndex), for `all` the scene textures each leaf uses,
/// ascending (leafTextures), and the tiles of split textures each leaf's
/// triangles use (leafTiles). The index is moved in (TextureBlocks::texture_index):
/// a city's is tens of megabytes.
TextureBlocks planTextureBlocks(const Scene& scene, const atlas::AtlasTree& tree, bool all, bool split,
                                TextureIndex texture_index,
                                const std::vector<std::vector<int32_t>>& leaf_textures,
                                const std::vector<std::vector<int32_t>>& leaf_tiles,
                                const std::filesystem::path& scratch_dir = {});

/// Tileset texture numbers: each used scene texture's rank among the used
/// ones (a split texture takes one more number per tile, tiles/texture_tiles.h),
/// so a shard of a larger build numbers its leaves' textures as the whole
/// build does without seeing the other shards.
TextureIndex tilesetTextureIndex(const std::vector<uint8_t>& used, const TextureTable& textures, int atlas_size_px,
                                 bool split, const std::filesystem::path& scratch_dir = {});
/// Per node (leaves only; others empty): the scene textures its triangles use, ascending.
std::vector<std::vector<int32_t>> leafTextures(const atlas::AtlasTree& tree);
/// Per node (leaves only; others empty): the tileset textures of split
/// textures its triangles name once cut (as leafGeometry cuts them: tiles,
/// or the whole texture for a triangle that is not cut), ascending.
std::vector<std::vector<int32_t>> leafTiles(const Scene& scene, const atlas::AtlasTree& tree,
                                            const TextureIndex& texture_index, bool split);

/// Reads, encodes and writes every planned block to `out_dir/textures/`;
/// keeps offsets and sizes (TextureBlocks::written). An unreadable texture is a counted warning
/// (texture_unreadable) and gets kUnreadable; a block left with no readable
/// texture is not written, and the others are renumbered densely (textures'
/// blocks and node_blocks follow).
/// Blocks kept by content between builds of one folder (incremental rebuilds,
/// cli/shards.h): `key` names a block by what it holds (its textures, in
/// order; "" = not cacheable); a block whose key has a file in `from` is
/// linked from there instead of being read and encoded again, and every
/// written block is linked into `to` for the next build. Only blocks whose
/// textures all read are kept.
struct BlockCache {
    std::filesystem::path from, to;
    std::function<std::string(const std::vector<TextureEntry>& textures)> key;
    uint64_t reused = 0, encoded = 0;  ///< blocks, filled by writeTextureBlocks
};

Status writeTextureBlocks(const Scene& scene, BcQuality quality, const std::filesystem::path& out_dir,
                          Diagnostics& diagnostics, const std::function<void(uint64_t, uint64_t)>& progress,
                          TextureBlocks* blocks, BlockCache* cache = nullptr);

/// Reads an image file as 8-bit, `channels` (3 or 4) channels, rows top-down;
/// grey and grey+alpha are expanded. Empty optional-like: returns false with a reason.
/// Colours as the file stores them, straight alpha (OpenImageIO would premultiply
/// them on read): what the client blends, the mip downsampler expects and glTF wants.
bool readImage8(const std::string& path, int channels, Image8* out, std::string* why);

}  // namespace cityatlas::tiles
