// SPDX-License-Identifier: GPL-3.0-or-later
#include "tiles/texture_codec.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <system_error>

#include <fmt/format.h>
#include <squish.h>
#include <stb_dxt.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include "core/srgb.h"

namespace cityatlas::tiles {
namespace {

using format::dds_detail::blockSize;
using format::dds_detail::fourCC;

void checkImage(const Image8& img, const char* what) {
    if (img.channels != 1 && img.channels != 3 && img.channels != 4)
        throw std::invalid_argument(fmt::format("{}: {} channels, expected 1, 3 or 4", what, img.channels));
    if (img.width < 1 || img.height < 1)
        throw std::invalid_argument(fmt::format("{}: empty image {}x{}", what, img.width, img.height));
    const size_t want = size_t(img.width) * size_t(img.height) * size_t(img.channels);
    if (img.pixels.size() != want)
        throw std::invalid_argument(
            fmt::format("{}: {} pixel bytes for {}x{}x{}, expected {}", what, img.pixels.size(), img.width,
                        img.height, img.channels, want));
}

// sRGB transfer (IEC 61966-2-1). Encoding goes through a table of decision
// thresholds instead of pow(): code k is chosen for linear values in
// [lin((k-0.5)/255), lin((k+0.5)/255)), which is exactly "round to the nearest
// code in sRGB space", and stays cheap for big levels.
struct SrgbTables {
    std::array<double, 256> to_linear{};
    std::array<double, 255> thresholds{};  // linear value where code k+1 starts
    SrgbTables() {
        for (int k = 0; k < 256; ++k) to_linear[size_t(k)] = linearFromSrgb(k / 255.0);
        for (int k = 0; k < 255; ++k) thresholds[size_t(k)] = linearFromSrgb((k + 0.5) / 255.0);
    }
    uint8_t encode(double linear) const {
        return uint8_t(std::upper_bound(thresholds.begin(), thresholds.end(), linear) - thresholds.begin());
    }
};

const SrgbTables& srgb() {
    static const SrgbTables tables;  // thread-safe static init (C++11)
    return tables;
}

// Footprint of output texel `o` along an axis of `in` input texels: [2o, 2o+2),
// widened to the end of the axis for the last texel when `in` is odd (or 1).
struct Span {
    int begin, end;
};
std::vector<Span> footprints(int in) {
    const int out = std::max(1, in / 2);
    std::vector<Span> spans(static_cast<size_t>(out));
    for (int o = 0; o < out; ++o) spans[size_t(o)] = {2 * o, o == out - 1 ? in : 2 * o + 2};
    return spans;
}

// One channel is a linear scalar (a computed texture's value in [0, 1]): the plain mean, rounded.
void downsampleScalar(const Image8& src, const std::vector<Span>& xs, const std::vector<Span>& ys, Image8* dst) {
    for (int oy = 0; oy < dst->height; ++oy)
        for (int ox = 0; ox < dst->width; ++ox) {
            const Span sy = ys[size_t(oy)], sx = xs[size_t(ox)];
            int sum = 0;
            for (int y = sy.begin; y < sy.end; ++y)
                for (int x = sx.begin; x < sx.end; ++x) sum += src.pixels[size_t(y) * size_t(src.width) + size_t(x)];
            const int n = (sy.end - sy.begin) * (sx.end - sx.begin);
            dst->pixels[size_t(oy) * size_t(dst->width) + size_t(ox)] = uint8_t((2 * sum + n) / (2 * n));
        }
}

Image8 downsample(const Image8& src) {
    const SrgbTables& t = srgb();
    const int ch = src.channels;
    Image8 dst;
    dst.width = std::max(1, src.width / 2);
    dst.height = std::max(1, src.height / 2);
    dst.channels = ch;
    dst.pixels.resize(size_t(dst.width) * size_t(dst.height) * size_t(ch));
    const std::vector<Span> xs = footprints(src.width), ys = footprints(src.height);
    if (ch == 1) {
        downsampleScalar(src, xs, ys, &dst);
        return dst;
    }

    tbb::parallel_for(tbb::blocked_range<int>(0, dst.height), [&](const tbb::blocked_range<int>& rows) {
        for (int oy = rows.begin(); oy < rows.end(); ++oy) {
            const Span sy = ys[size_t(oy)];
            for (int ox = 0; ox < dst.width; ++ox) {
                const Span sx = xs[size_t(ox)];
                double plain[3] = {0, 0, 0}, weighted[3] = {0, 0, 0}, alpha_sum = 0;
                for (int y = sy.begin; y < sy.end; ++y) {
                    const uint8_t* p = &src.pixels[(size_t(y) * size_t(src.width) + size_t(sx.begin)) * size_t(ch)];
                    for (int x = sx.begin; x < sx.end; ++x, p += ch) {
                        const double a = ch == 4 ? p[3] / 255.0 : 1.0;
                        alpha_sum += a;
                        for (int c = 0; c < 3; ++c) {
                            const double l = t.to_linear[p[c]];
                            plain[c] += l;
                            weighted[c] += l * a;
                        }
                    }
                }
                const double n = double(sy.end - sy.begin) * double(sx.end - sx.begin);
                uint8_t* d = &dst.pixels[(size_t(oy) * size_t(dst.width) + size_t(ox)) * size_t(ch)];
                // Premultiplied mean, un-premultiplied for the straight-alpha output:
                // transparent texels then do not darken or tint their neighbours.
                // With no coverage at all there is nothing to weight by, so the plain
                // mean keeps a sensible colour under the (invisible) texel.
                for (int c = 0; c < 3; ++c)
                    d[c] = t.encode(alpha_sum > 0 ? weighted[c] / alpha_sum : plain[c] / n);
                if (ch == 4) d[3] = uint8_t(std::lround(255.0 * alpha_sum / n));
            }
        }
    });
    return dst;
}


// One 4x4 block as RGBA (the layout both encoders take), edges replicated.
// Three-channel sources get alpha 255: squish's kDxt1 would otherwise turn
// alpha < 128 into BC1's transparent-black index.
void gatherBlock(const Image8& img, int bx, int by, uint8_t rgba[64]) {
    for (int py = 0; py < 4; ++py) {
        const int sy = std::min(by * 4 + py, img.height - 1);
        for (int px = 0; px < 4; ++px) {
            const int sx = std::min(bx * 4 + px, img.width - 1);
            const uint8_t* p = &img.pixels[(size_t(sy) * size_t(img.width) + size_t(sx)) * size_t(img.channels)];
            uint8_t* q = &rgba[(py * 4 + px) * 4];
            q[0] = p[0];
            q[1] = p[1];
            q[2] = p[2];
            q[3] = img.channels == 4 ? p[3] : 255;
        }
    }
}

// One 4x4 block of a one-channel image, edges replicated.
void gatherScalarBlock(const Image8& img, int bx, int by, uint8_t v[16]) {
    for (int py = 0; py < 4; ++py) {
        const int sy = std::min(by * 4 + py, img.height - 1);
        for (int px = 0; px < 4; ++px)
            v[py * 4 + px] = img.pixels[size_t(sy) * size_t(img.width) + size_t(std::min(bx * 4 + px, img.width - 1))];
    }
}

void put32(std::vector<uint8_t>& out, uint32_t v) {
    for (int i = 0; i < 4; ++i) out.push_back(uint8_t(v >> (8 * i)));  // DDS is little-endian
}


// DDS_HEADER flags and caps (Microsoft "DDS_HEADER structure").
constexpr uint32_t kDdsdCaps = 0x1, kDdsdHeight = 0x2, kDdsdWidth = 0x4, kDdsdPixelFormat = 0x1000,
                   kDdsdMipMapCount = 0x20000, kDdsdLinearSize = 0x80000;
using format::dds_detail::kDdpfFourCC;
constexpr uint32_t kCapsComplex = 0x8, kCapsTexture = 0x1000, kCapsMipMap = 0x400000;

}  // namespace

std::string_view bcQualityName(BcQuality q) {
    switch (q) {
        case BcQuality::Fast: return "fast";
        case BcQuality::Best: return "best";
    }
    return "fast";  // unreachable for valid enumerators; keeps -Wreturn-type quiet
}

std::optional<BcQuality> bcQualityFromName(std::string_view name) {
    if (name == "fast") return BcQuality::Fast;
    if (name == "best") return BcQuality::Best;
    return std::nullopt;
}

std::vector<Image8> mipChain(const Image8& base) {
    checkImage(base, "mipChain");
    std::vector<Image8> chain{base};
    while (chain.back().width > 1 || chain.back().height > 1) chain.push_back(downsample(chain.back()));
    return chain;
}

std::vector<uint8_t> encodeBc(const Image8& image, BcQuality quality) {
    checkImage(image, "encodeBc");
    const int bw = (image.width + 3) / 4, bh = (image.height + 3) / 4;
    const size_t bsize = blockSize(image.channels);
    const bool alpha = image.channels == 4;
    std::vector<uint8_t> out(size_t(bw) * size_t(bh) * bsize);
    // Each block is a pure function of its 16 texels and lands at a fixed
    // offset, so the bytes are the same for any thread count or split.
    // Grain: stb takes ~1 us a block, so a task gets at least a block row;
    // squish cluster fit takes ~50 us a block, so single blocks are worth a task.
    const size_t grain = quality == BcQuality::Fast ? size_t(std::max(bw, 64)) : 1;
    const int squish_flags = (alpha ? squish::kDxt5 : squish::kDxt1) | squish::kColourClusterFit;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, size_t(bw) * size_t(bh), grain),
                      [&](const tbb::blocked_range<size_t>& r) {
                          uint8_t rgba[64];
                          for (size_t i = r.begin(); i < r.end(); ++i) {
                              uint8_t* dst = &out[i * bsize];
                              if (image.channels == 1) {  // BC4: stb at either quality (libsquish has none)
                                  gatherScalarBlock(image, int(i % size_t(bw)), int(i / size_t(bw)), rgba);
                                  stb_compress_bc4_block(dst, rgba);
                                  continue;
                              }
                              gatherBlock(image, int(i % size_t(bw)), int(i / size_t(bw)), rgba);
                              if (quality == BcQuality::Fast)
                                  stb_compress_dxt_block(dst, rgba, alpha ? 1 : 0, STB_DXT_HIGHQUAL);
                              else  // metric = null: uniform RGB weights, the measure psnrRgb reports
                                  squish::Compress(rgba, dst, squish_flags);
                          }
                      });
    return out;
}

std::vector<uint8_t> encodeDds(const std::vector<Image8>& mips, BcQuality quality) {
    if (mips.empty()) throw std::invalid_argument("encodeDds: no mip levels");
    for (size_t i = 0; i < mips.size(); ++i) {
        checkImage(mips[i], "encodeDds");
        if (i == 0) continue;
        const Image8& prev = mips[i - 1];
        if (mips[i].channels != mips[0].channels)
            throw std::invalid_argument(fmt::format("encodeDds: level {} has {} channels, level 0 has {}", i,
                                                    mips[i].channels, mips[0].channels));
        // Readers derive each level's size from level 0, so a level that is not
        // exactly the halved previous one (or one past 1x1) would be misread.
        if ((prev.width == 1 && prev.height == 1) || mips[i].width != std::max(1, prev.width / 2) ||
            mips[i].height != std::max(1, prev.height / 2))
            throw std::invalid_argument(fmt::format("encodeDds: level {} is {}x{} after {}x{}", i, mips[i].width,
                                                    mips[i].height, prev.width, prev.height));
    }
    const Image8& base = mips[0];
    const bool many = mips.size() > 1;
    std::vector<uint8_t> out;
    out.reserve(128 + bcBlockBytes(base.width, base.height, base.channels) * 4 / 3 + 64);
    put32(out, fourCC("DDS "));
    put32(out, 124);  // dwSize
    put32(out, kDdsdCaps | kDdsdHeight | kDdsdWidth | kDdsdPixelFormat | kDdsdMipMapCount | kDdsdLinearSize);
    put32(out, uint32_t(base.height));
    put32(out, uint32_t(base.width));
    put32(out, uint32_t(bcBlockBytes(base.width, base.height, base.channels)));  // dwPitchOrLinearSize
    put32(out, 0);                                                               // dwDepth
    put32(out, uint32_t(mips.size()));                                           // dwMipMapCount
    for (int i = 0; i < 11; ++i) put32(out, 0);                                  // dwReserved1
    put32(out, 32);                                                              // ddspf.dwSize
    put32(out, kDdpfFourCC);                                                     // ddspf.dwFlags
    put32(out, fourCC(base.channels == 1 ? "DX10" : base.channels == 3 ? "DXT1" : "DXT5"));
    for (int i = 0; i < 5; ++i) put32(out, 0);  // bit count and the four masks (unused with FourCC)
    put32(out, kCapsTexture | (many ? kCapsMipMap | kCapsComplex : 0u));
    for (int i = 0; i < 4; ++i) put32(out, 0);  // dwCaps2..4, dwReserved2
    if (base.channels == 1) {  // BC4 has no FourCC of its own everyone reads: the DX10 header
        put32(out, format::dds_detail::kDxgiBc4Unorm);
        put32(out, format::dds_detail::kDimensionTexture2d);
        put32(out, 0);  // miscFlag
        put32(out, 1);  // arraySize
        put32(out, 0);  // miscFlags2: alpha mode unknown
    }
    for (const Image8& level : mips) {
        const std::vector<uint8_t> blocks = encodeBc(level, quality);
        out.insert(out.end(), blocks.begin(), blocks.end());
    }
    return out;
}

Status writeDds(const std::filesystem::path& path, const std::vector<Image8>& mips, BcQuality quality) {
    const std::vector<uint8_t> bytes = encodeDds(mips, quality);
    // Unique per process and call, so concurrent writers never share a temporary.
    static std::atomic<unsigned> counter{0};
    std::filesystem::path tmp = path;
    tmp += fmt::format(".{}.{}.tmp", long(::getpid()), counter++);

    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) return Status::Io(fmt::format("{}: cannot create: {}", path.string(), std::strerror(errno)));
    const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
    const int write_errno = errno;
    // fclose flushes: a full disk can first show up here.
    const bool closed = std::fclose(f) == 0;
    const int close_errno = errno;
    std::error_code ec;
    if (!written || !closed) {
        std::filesystem::remove(tmp, ec);
        return Status::Io(fmt::format("{}: cannot write: {}", path.string(),
                                        std::strerror(!written ? write_errno : close_errno)));
    }
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::error_code ignored;
        std::filesystem::remove(tmp, ignored);
        return Status::Invalid(fmt::format("{}: cannot rename into place: {}", path.string(), ec.message()));
    }
    return Status::Ok();
}

double psnrRgb(const Image8& a, const Image8& b) {
    checkImage(a, "psnrRgb");
    checkImage(b, "psnrRgb");
    if (a.width != b.width || a.height != b.height)
        throw std::invalid_argument(
            fmt::format("psnrRgb: {}x{} against {}x{}", a.width, a.height, b.width, b.height));
    const size_t n = size_t(a.width) * size_t(a.height);
    double sq = 0;
    for (size_t i = 0; i < n; ++i)
        for (size_t c = 0; c < 3; ++c) {
            const double d = double(a.pixels[i * size_t(a.channels) + c]) - double(b.pixels[i * size_t(b.channels) + c]);
            sq += d * d;
        }
    if (sq == 0) return std::numeric_limits<double>::infinity();
    const double mse = sq / double(n * 3);
    return 10.0 * std::log10(255.0 * 255.0 / mse);
}

}  // namespace cityatlas::tiles
