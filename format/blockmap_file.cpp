// SPDX-License-Identifier: GPL-3.0-or-later
// The BlockMap file (blockmap_file.h): zstd sections, BC1 colour, checks.
#include "format/blockmap_file.h"

#include <xxhash.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cstring>

#include <fmt/format.h>

#include "format/dds.h"
#include "format/little_endian.h"

namespace cityatlas::format {
namespace {

constexpr char kMagic[4] = {'C', 'A', 'B', 'M'};
constexpr size_t kHeaderBytes = 76;

// Appends a section: its byte count, then the bytes (zstd level 19 when `compress`).
void putSection(std::vector<uint8_t>* out, std::span<const uint8_t> raw, bool compress) {
    std::vector<uint8_t> z;
    if (compress) {
        z.resize(ZSTD_compressBound(raw.size()));
        const size_t n = ZSTD_compress(z.data(), z.size(), raw.data(), raw.size(), 19);
        z.resize(ZSTD_isError(n) ? 0 : n);
        raw = z;
    }
    const size_t at = out->size();
    out->resize(at + 8 + raw.size());
    putLe<uint64_t>(out->data() + at, raw.size());
    if (!raw.empty()) std::memcpy(out->data() + at + 8, raw.data(), raw.size());
}

// Reads sections in order from a cursor; every failure names the section.
class Sections {
public:
    Sections(std::span<const uint8_t> bytes, const std::string& where) : bytes_(bytes), where_(&where) {}
    Status next(const char* name, bool compressed, size_t expected, std::vector<uint8_t>* out) {
        if (bytes_.size() - at_ < 8) return fail(fmt::format("{}: truncated before its size", name));
        const uint64_t n = getLe<uint64_t>(bytes_.data() + at_);
        at_ += 8;
        if (n > bytes_.size() - at_) return fail(fmt::format("{}: {} bytes announced, {} left", name, n, bytes_.size() - at_));
        const std::span<const uint8_t> payload = bytes_.subspan(at_, n);
        at_ += n;
        if (!compressed) {
            if (n != expected) return fail(fmt::format("{}: {} bytes, expected {}", name, n, expected));
            out->assign(payload.begin(), payload.end());
            return Status::Ok();
        }
        const unsigned long long size = ZSTD_getFrameContentSize(payload.data(), payload.size());
        if (size != expected) return fail(fmt::format("{}: not a zstd frame of {} bytes", name, expected));
        out->resize(expected);
        const size_t got = ZSTD_decompress(out->data(), out->size(), payload.data(), payload.size());
        if (ZSTD_isError(got) || got != expected) return fail(fmt::format("{}: zstd: {}", name, ZSTD_isError(got) ? ZSTD_getErrorName(got) : "short"));
        return Status::Ok();
    }
    bool atEnd() const { return at_ == bytes_.size(); }
    Status fail(const std::string& what) const {
        return Status::Fail(StatusCode::kInvalidInput, fmt::format("{}: BlockMap: {}", *where_, what));
    }
    void skip(size_t n) { at_ += n; }

private:
    std::span<const uint8_t> bytes_;
    const std::string* where_;
    size_t at_ = 0;
};

constexpr size_t kCellBytes = 12, kColumnBytes = 14;

// The cells and columns agree as the ray caster needs: each occupied cell's
// columns are its exposed sides in order, each naming it; nothing else.
Status checkPlanes(const BlockMap& bm, const Sections& s) {
    uint64_t expected_columns = 0;
    for (int y = 0; y < bm.ny; ++y)
        for (int x = 0; x < bm.nx; ++x) {
            const BlockMapCell& c = bm.cells[bm.index(x, y)];
            if (!c.occupied()) {
                if (c.top != 0 || c.base != 0 || c.first_column != kBlockMapNone)
                    return s.fail(fmt::format("cell {},{}: empty but with a height or a column", x, y));
                continue;
            }
            if (c.feature >= bm.features.size()) return s.fail(fmt::format("cell {},{}: building {} of {}", x, y, c.feature, bm.features.size()));
            if (c.top == 0 || c.base > c.top) return s.fail(fmt::format("cell {},{}: base {} above top {}", x, y, c.base, c.top));
            const uint8_t mask = bm.exposedSides(x, y);
            if (mask == 0) {
                if (c.first_column != kBlockMapNone) return s.fail(fmt::format("cell {},{}: a column without an exposed side", x, y));
                continue;
            }
            if (c.first_column != expected_columns)
                return s.fail(fmt::format("cell {},{}: first column {}, expected {}", x, y, c.first_column, expected_columns));
            for (int k = 0; k < 4; ++k) {
                if (!(mask >> k & 1u)) continue;
                if (expected_columns >= bm.columns.size()) return s.fail(fmt::format("cell {},{}: columns run out", x, y));
                const BlockMapColumn& col = bm.columns[expected_columns++];
                if (col.cell != bm.index(x, y) || col.side != k)
                    return s.fail(fmt::format("column {}: names cell {} side {}, expected {} side {}", expected_columns - 1, col.cell,
                                              col.side, bm.index(x, y), k));
                if (col.rows == 0 || col.base > c.top || col.x >= bm.wall_width ||
                    static_cast<uint32_t>(col.y) + col.rows > static_cast<uint32_t>(bm.wall_height))
                    return s.fail(fmt::format("column {}: outside the wall image or its cell", expected_columns - 1));
            }
        }
    if (expected_columns != bm.columns.size())
        return s.fail(fmt::format("{} columns, the cells expose {} sides", bm.columns.size(), expected_columns));
    return Status::Ok();
}

}  // namespace

std::vector<uint8_t> encodeBlockMapFile(const BlockMap& bm, std::span<const uint8_t> roof_bc1, std::span<const uint8_t> walls_bc1) {
    std::vector<uint8_t> out(kHeaderBytes);
    uint8_t* h = out.data();
    std::memcpy(h, kMagic, 4);
    putLe<uint32_t>(h + 4, kBlockMapFileVersion);
    putLe<uint32_t>(h + 8, static_cast<uint32_t>(bm.nx));
    putLe<uint32_t>(h + 12, static_cast<uint32_t>(bm.ny));
    const double doubles[5] = {bm.cell_m, bm.origin.x, bm.origin.y, bm.origin.z, bm.z_hi};
    for (size_t i = 0; i < 5; ++i) putLe<double>(h + 16 + 8 * i, doubles[i]);
    putLe<uint32_t>(h + 56, static_cast<uint32_t>(bm.columns.size()));
    putLe<uint32_t>(h + 60, static_cast<uint32_t>(bm.features.size()));
    putLe<uint32_t>(h + 64, static_cast<uint32_t>(bm.wall_width));
    putLe<uint32_t>(h + 68, static_cast<uint32_t>(bm.wall_height));
    const bool coloured = !roof_bc1.empty();
    putLe<uint32_t>(h + 72, coloured ? 1u : 0u);
    std::vector<uint8_t> raw(bm.cells.size() * kCellBytes);
    for (size_t i = 0; i < bm.cells.size(); ++i) {
        const BlockMapCell& c = bm.cells[i];
        uint8_t* p = raw.data() + i * kCellBytes;
        putLe(p, c.top), putLe(p + 2, c.base), putLe(p + 4, c.feature), putLe(p + 8, c.first_column);
    }
    putSection(&out, raw, true);
    raw.assign(bm.columns.size() * kColumnBytes, 0);
    for (size_t i = 0; i < bm.columns.size(); ++i) {
        const BlockMapColumn& c = bm.columns[i];
        uint8_t* p = raw.data() + i * kColumnBytes;
        putLe(p, c.cell), putLe(p + 4, c.side), putLe(p + 6, c.base), putLe(p + 8, c.rows), putLe(p + 10, c.x), putLe(p + 12, c.y);
    }
    putSection(&out, raw, true);
    raw.assign(bm.features.size() * 4, 0);
    for (size_t i = 0; i < bm.features.size(); ++i) putLe(raw.data() + i * 4, bm.features[i]);
    putSection(&out, raw, true);
    if (coloured) {
        putSection(&out, roof_bc1, false);
        putSection(&out, walls_bc1, false);
    }
    const size_t at = out.size();
    out.resize(at + 8);
    putLe<uint64_t>(out.data() + at, XXH64(out.data(), at, 0));
    return out;
}

Status decodeBlockMapFile(std::span<const uint8_t> bytes, const std::string& where, BlockMap* out) {
    *out = BlockMap{};
    Sections s(bytes, where);
    if (bytes.size() < kHeaderBytes + 8 || std::memcmp(bytes.data(), kMagic, 4) != 0) return s.fail("not a BlockMap file (magic)");
    // The checksum first: a flipped bit in the colour blocks is a valid colour otherwise.
    if (getLe<uint64_t>(bytes.data() + bytes.size() - 8) != XXH64(bytes.data(), bytes.size() - 8, 0))
        return s.fail("checksum mismatch (a truncated or damaged file)");
    bytes = bytes.first(bytes.size() - 8);
    s = Sections(bytes, where);
    const uint8_t* h = bytes.data();
    if (getLe<uint32_t>(h + 4) != kBlockMapFileVersion) return s.fail(fmt::format("version {}, this reader knows 1", getLe<uint32_t>(h + 4)));
    const uint32_t nx = getLe<uint32_t>(h + 8), ny = getLe<uint32_t>(h + 12);
    BlockMap& bm = *out;
    bm.cell_m = getLe<double>(h + 16);
    bm.origin = {getLe<double>(h + 24), getLe<double>(h + 32), getLe<double>(h + 40)};
    bm.z_hi = getLe<double>(h + 48);
    const uint32_t columns = getLe<uint32_t>(h + 56), features = getLe<uint32_t>(h + 60);
    const uint32_t wall_width = getLe<uint32_t>(h + 64), wall_height = getLe<uint32_t>(h + 68), flags = getLe<uint32_t>(h + 72);
    // The limits (format/blockmap.h) also keep a hostile header from asking for absurd memory.
    if (nx == 0 || ny == 0 || static_cast<uint64_t>(nx) * ny > kBlockMapMaxCells) return s.fail(fmt::format("grid {} x {}", nx, ny));
    // Local frames are metres within a city's or a state's reach: anything else is damage.
    const auto within = [](double v, double limit) { return std::isfinite(v) && std::abs(v) <= limit; };
    if (!(bm.cell_m >= 1e-3 && bm.cell_m <= 1e5) || !within(bm.origin.x, 1e7) || !within(bm.origin.y, 1e7) ||
        !within(bm.origin.z, 1e5) || !within(bm.z_hi, 1e5) || !(bm.z_hi > bm.origin.z))
        return s.fail("cell size, origin or height range out of range (cell 1 mm to 100 km, |origin| <= 10,000 km)");
    if (columns > kBlockMapMaxColumns || features > nx * ny || wall_width == 0 || wall_width > 65535 || wall_height > static_cast<uint32_t>(kBlockMapMaxWallHeight) ||
        (flags & ~1u) != 0)
        return s.fail(fmt::format("counts out of range (columns {}, buildings {}, wall {} x {}, flags {})", columns, features, wall_width,
                                  wall_height, flags));
    bm.nx = static_cast<int>(nx), bm.ny = static_cast<int>(ny);
    bm.wall_width = static_cast<int>(wall_width), bm.wall_height = static_cast<int>(wall_height);
    s.skip(kHeaderBytes);
    const size_t n = static_cast<size_t>(nx) * ny;
    std::vector<uint8_t> raw;
    if (Status st = s.next("cells", true, n * kCellBytes, &raw); !st.ok()) return st;
    bm.cells.resize(n);
    for (size_t i = 0; i < n; ++i) {
        const uint8_t* p = raw.data() + i * kCellBytes;
        bm.cells[i] = {getLe<uint16_t>(p), getLe<uint16_t>(p + 2), getLe<uint32_t>(p + 4), getLe<uint32_t>(p + 8)};
    }
    if (Status st = s.next("columns", true, static_cast<size_t>(columns) * kColumnBytes, &raw); !st.ok()) return st;
    bm.columns.resize(columns);
    for (size_t i = 0; i < columns; ++i) {
        const uint8_t* p = raw.data() + i * kColumnBytes;
        bm.columns[i] = {getLe<uint32_t>(p), p[4], getLe<uint16_t>(p + 6), getLe<uint16_t>(p + 8), getLe<uint16_t>(p + 10), getLe<uint16_t>(p + 12)};
    }
    if (Status st = s.next("features", true, static_cast<size_t>(features) * 4, &raw); !st.ok()) return st;
    bm.features.resize(features);
    for (size_t i = 0; i < features; ++i) bm.features[i] = getLe<uint32_t>(raw.data() + i * 4);
    if (Status st = checkPlanes(bm, s); !st.ok()) return st;
    if (flags & 1u) {
        if (Status st = s.next("roof", false, bcBlockBytes(bm.nx, bm.ny, 3), &raw); !st.ok()) return st;
        bm.roof = decodeBc(raw, bm.nx, bm.ny, 3).pixels;
        if (bm.wall_height > 0) {
            if (Status st = s.next("walls", false, bcBlockBytes(bm.wall_width, bm.wall_height, 3), &raw); !st.ok()) return st;
            bm.walls = decodeBc(raw, bm.wall_width, bm.wall_height, 3).pixels;
        } else if (Status st = s.next("walls", false, 0, &raw); !st.ok()) {
            return st;
        }
    }
    if (!s.atEnd()) return s.fail("bytes after the last section");
    bm.dist = chebyshevDistances(bm);
    return Status::Ok();
}

}  // namespace cityatlas::format
