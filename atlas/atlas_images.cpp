// SPDX-License-Identifier: GPL-3.0-or-later
//
// Leaf atlases are resampled here rather than with ImageBufAlgo::resize or
// ::warp: a packed region can show a texture repeated hundreds of times, and
// neither call combines periodic wrapping with a minification of 1000:1 at a
// cost independent of the repeat count. What this does instead is what a
// mipmapped texture unit does, with a real kernel: reduce one period of the
// texture by box filtering until less than 2:1 remains (exactly periodic,
// since the reduced width divides the period), then resample separably with
// the chosen kernel, wrapping indices as the texture's wrap mode says. All
// filtering happens on linear-light, premultiplied-alpha floats.
// OpenImageIO does the reading (ImageInput, into a bounded cache of decoded
// textures) and writing.
#include "atlas/atlas_images.h"
#include "atlas/texture_file.h"
#include "atlas/placement.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <unordered_map>

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <tbb/task_group.h>

namespace cityatlas::atlas {

namespace fs = std::filesystem;

namespace {

struct ColourTables {
    std::vector<float> to_linear;    // 16-bit sRGB code -> linear
    std::vector<uint8_t> to_srgb8;   // linear quantised to 16 bits -> 8-bit sRGB code
    ColourTables() : to_linear(65536), to_srgb8(65536) {
        for (int i = 0; i < 65536; ++i) {
            to_linear[i] = static_cast<float>(linearFromSrgb(i / 65535.0));
            to_srgb8[i] = static_cast<uint8_t>(std::lround(255.0 * srgbFromLinear(i / 65535.0)));
        }
    }
};
const ColourTables& tables() {
    static const ColourTables t;
    return t;
}

// A float RGBA image, premultiplied linear light, rows top-down as in files.
struct Image {
    int w = 0, h = 0;
    std::vector<float> px;
    float* at(int x, int y) { return &px[(static_cast<size_t>(y) * w + x) * 4]; }
    const float* at(int x, int y) const { return &px[(static_cast<size_t>(y) * w + x) * 4]; }
};

int wrapIndex(int i, int n, WrapMode mode) {
    if (mode == WrapMode::Wrap) {
        const int m = i % n;
        return m < 0 ? m + n : m;
    }
    if (mode == WrapMode::Mirror) {
        const int period = 2 * n;
        int m = i % period;
        if (m < 0) m += period;
        return m < n ? m : period - 1 - m;
    }
    return std::clamp(i, 0, n - 1);
}

// Box reduction along one axis from n to floor(n/2) texels: output texel i
// averages the input interval [i*r, (i+1)*r), r = n / floor(n/2), with
// fractional weights at the ends. One period maps to one period.
Image reduceAxis(const Image& in, bool along_x) {
    const int n = along_x ? in.w : in.h;
    const int m = n / 2;
    const double r = static_cast<double>(n) / m;
    // Per output texel: the input texels it averages and their weights (two
    // halves of 1/2 when n is even; fractional ends when it is odd).
    std::vector<int> first(m), count(m);
    std::vector<int> index;
    std::vector<float> weight;
    for (int i = 0; i < m; ++i) {
        const double lo = i * r, hi = (i + 1) * r;
        first[i] = static_cast<int>(index.size());
        for (int k = static_cast<int>(std::floor(lo)); k < static_cast<int>(std::ceil(hi)) && k < n; ++k) {
            const double w = (std::min<double>(hi, k + 1) - std::max<double>(lo, k)) / r;
            if (w <= 0) continue;
            index.push_back(k);
            weight.push_back(static_cast<float>(w));
        }
        count[i] = static_cast<int>(index.size()) - first[i];
    }
    Image out;
    out.w = along_x ? m : in.w;
    out.h = along_x ? in.h : m;
    out.px.assign(static_cast<size_t>(out.w) * out.h * 4, 0.0f);
    if (along_x) {
        for (int y = 0; y < in.h; ++y)
            for (int i = 0; i < m; ++i) {
                float* d = out.at(i, y);
                for (int j = first[i]; j < first[i] + count[i]; ++j) {
                    const float* s = in.at(index[j], y);
                    for (int c = 0; c < 4; ++c) d[c] += weight[j] * s[c];
                }
            }
    } else {
        const size_t row = static_cast<size_t>(in.w) * 4;
        for (int i = 0; i < m; ++i) {
            float* d = out.at(0, i);
            for (int j = first[i]; j < first[i] + count[i]; ++j) {
                const float* s = in.at(0, index[j]);
                const float w = weight[j];
                for (size_t k = 0; k < row; ++k) d[k] += w * s[k];
            }
        }
    }
    return out;
}

double kernelRadius(ResampleFilter f) {
    switch (f) {
        case ResampleFilter::Box: return 0.5;
        case ResampleFilter::Triangle: return 1.0;
        case ResampleFilter::Mitchell: return 2.0;
        case ResampleFilter::Lanczos3: return 3.0;
    }
    return 1.0;
}

double sinc(double x) {
    if (std::abs(x) < 1e-8) return 1.0;
    const double px = M_PI * x;
    return std::sin(px) / px;
}

double kernel(ResampleFilter f, double x) {
    const double a = std::abs(x);
    switch (f) {
        case ResampleFilter::Box: return a < 0.5 ? 1.0 : (a == 0.5 ? 0.5 : 0.0);
        case ResampleFilter::Triangle: return a < 1 ? 1 - a : 0;
        case ResampleFilter::Mitchell: {  // B = C = 1/3
            constexpr double B = 1.0 / 3.0, C = 1.0 / 3.0;
            if (a < 1) return ((12 - 9 * B - 6 * C) * a * a * a + (-18 + 12 * B + 6 * C) * a * a + (6 - 2 * B)) / 6;
            if (a < 2)
                return ((-B - 6 * C) * a * a * a + (6 * B + 30 * C) * a * a + (-12 * B - 48 * C) * a + (8 * B + 24 * C)) / 6;
            return 0;
        }
        case ResampleFilter::Lanczos3: return a < 3 ? sinc(a) * sinc(a / 3) : 0;
    }
    return 0;
}

struct Taps {
    std::vector<int> first;             // per sample: index into index/weight
    std::vector<int> count;
    std::vector<int> index;             // wrapped source index
    std::vector<float> weight;
};

// Kernel taps for samples at continuous source positions (texel centres at
// i + 0.5), widened by the remaining minification so it stays a low-pass.
Taps makeTaps(const std::vector<double>& pos, double spacing, int n, WrapMode wrap, ResampleFilter f) {
    Taps t;
    const double scale = std::max(1.0, spacing), radius = kernelRadius(f) * scale;
    for (double p : pos) {
        t.first.push_back(static_cast<int>(t.index.size()));
        const int lo = static_cast<int>(std::floor(p - radius - 0.5)), hi = static_cast<int>(std::ceil(p + radius - 0.5));
        double sum = 0;
        const size_t start = t.index.size();
        for (int i = lo; i <= hi; ++i) {
            const double w = kernel(f, (i + 0.5 - p) / scale);
            if (w == 0) continue;
            t.index.push_back(wrapIndex(i, n, wrap));
            t.weight.push_back(static_cast<float>(w));
            sum += w;
        }
        if (!(std::abs(sum) > 1e-12)) {  // a box exactly between texels: take the nearest
            t.index.resize(start), t.weight.resize(start);
            t.index.push_back(wrapIndex(static_cast<int>(std::floor(p)), n, wrap));
            t.weight.push_back(1.0f);
            sum = 1;
        }
        for (size_t k = start; k < t.weight.size(); ++k) t.weight[k] = static_cast<float>(t.weight[k] / sum);
        t.count.push_back(static_cast<int>(t.index.size() - start));
    }
    return t;
}

// A leaf or inner atlas under construction: premultiplied linear RGBA, rows
// bottom-up (y = v), as atlas texel coordinates are.
using Canvas = AtlasCanvas;

// How many halvings of the source each axis needs before less than 2:1
// minification is left (a texture mipmap's level choice, per axis).
std::pair<int, int> reductionLevels(const PackedRegion& r, int src_w, int src_h) {
    const int n_u = r.rotated ? r.h : r.w, n_v = r.rotated ? r.w : r.h;
    double spacing_u = (r.uv_max.x - r.uv_min.x) * src_w / n_u, spacing_v = (r.uv_max.y - r.uv_min.y) * src_h / n_v;
    int lu = 0, lv = 0;
    for (int w = src_w; spacing_u >= 2.0 && w >= 2; w /= 2, ++lu) spacing_u /= static_cast<double>(w) / (w / 2);
    for (int h = src_h; spacing_v >= 2.0 && h >= 2; h /= 2, ++lv) spacing_v /= static_cast<double>(h) / (h / 2);
    return {lu, lv};
}

// Rows first: each halving of the height halves the work of the width's.
Image reduced(const Image& full, int levels_u, int levels_v) {
    Image img;
    const Image* cur = &full;
    for (int k = 0; k < levels_v; ++k) img = reduceAxis(*cur, false), cur = &img;
    for (int k = 0; k < levels_u; ++k) img = reduceAxis(*cur, true), cur = &img;
    return img;
}

// `src` is the texture already reduced as reductionLevels() says.
void resampleRegion(const Image& src_img, const PackedRegion& r, WrapMode wrap, ResampleFilter filter, Canvas& canvas) {
    const int n_u = r.rotated ? r.h : r.w, n_v = r.rotated ? r.w : r.h;
    const double du = r.uv_max.x - r.uv_min.x, dv = r.uv_max.y - r.uv_min.y;
    const Image* src = &src_img;
    const double spacing_u = du * src->w / n_u, spacing_v = dv * src->h / n_v;
    std::vector<double> pos_u(n_u), pos_v(n_v);
    for (int k = 0; k < n_u; ++k) pos_u[k] = (r.uv_min.x + (k + 0.5) / n_u * du) * src->w;
    for (int k = 0; k < n_v; ++k) pos_v[k] = (1.0 - (r.uv_min.y + (k + 0.5) / n_v * dv)) * src->h;  // rows top-down
    const Taps tu = makeTaps(pos_u, spacing_u, src->w, wrap, filter);
    const Taps tv = makeTaps(pos_v, spacing_v, src->h, wrap, filter);

    // Horizontal pass, only for the source rows the vertical taps touch.
    std::vector<int> slot(src->h, -1);
    int rows = 0;
    for (int idx : tv.index)
        if (slot[idx] < 0) slot[idx] = rows++;
    std::vector<float> horiz(static_cast<size_t>(rows) * n_u * 4, 0.0f);
    for (int y = 0; y < src->h; ++y) {
        if (slot[y] < 0) continue;
        float* out = &horiz[static_cast<size_t>(slot[y]) * n_u * 4];
        for (int k = 0; k < n_u; ++k) {
            float acc[4] = {0, 0, 0, 0};
            for (int j = tu.first[k]; j < tu.first[k] + tu.count[k]; ++j) {
                const float* s = src->at(tu.index[j], y);
                const float w = tu.weight[j];
                for (int c = 0; c < 4; ++c) acc[c] += w * s[c];
            }
            std::copy(acc, acc + 4, out + k * 4);
        }
    }
    for (int kv = 0; kv < n_v; ++kv) {
        for (int ku = 0; ku < n_u; ++ku) {
            float acc[4] = {0, 0, 0, 0};
            for (int j = tv.first[kv]; j < tv.first[kv] + tv.count[kv]; ++j) {
                const float* s = &horiz[(static_cast<size_t>(slot[tv.index[j]]) * n_u + ku) * 4];
                const float w = tv.weight[j];
                for (int c = 0; c < 4; ++c) acc[c] += w * s[c];
            }
            // Negative kernel lobes can overshoot: keep premultiplied colour in [0, alpha].
            const float a = std::clamp(acc[3], 0.0f, 1.0f);
            float* d = r.rotated ? canvas.at(r.x + (r.w - 1 - kv), r.y + ku) : canvas.at(r.x + ku, r.y + kv);
            for (int c = 0; c < 3; ++c) d[c] = std::clamp(acc[c], 0.0f, a);
            d[3] = a;
        }
    }
}

// 2x2 box mean into a canvas half the size: rectangles aligned to 4 texels
// stay clean for two halvings, then bleed one texel per level into their border.
Canvas halve(const Canvas& c) {
    Canvas h(c.w / 2, c.h / 2);  // sides are multiples of 4
    for (int y = 0; y < h.h; ++y)
        for (int x = 0; x < h.w; ++x) {
            float* d = h.at(x, y);
            const float* row0 = c.at(2 * x, 2 * y);
            const float* row1 = c.at(2 * x, 2 * y + 1);
            for (int k = 0; k < 4; ++k) d[k] = 0.25f * (row0[k] + row0[k + 4] + row1[k] + row1[k + 4]);
        }
    return h;
}

// The canvas as the 8-bit image its PNG holds: sRGB, rows top-down, straight alpha.
format::Image8 imageOf(const Canvas& c, Layer layer) {
    const int nc = layer == Layer::Opaque ? 3 : 4;
    const auto& t = tables();
    format::Image8 img;
    img.width = c.w;
    img.height = c.h;
    img.channels = nc;
    img.pixels.resize(static_cast<size_t>(c.w) * c.h * nc);
    for (int y = 0; y < c.h; ++y) {
        const int row = c.h - 1 - y;  // files run top-down
        for (int x = 0; x < c.w; ++x) {
            const float* s = c.at(x, y);
            uint8_t* d = &img.pixels[(static_cast<size_t>(row) * c.w + x) * nc];
            const float a = s[3];
            const float inv = layer == Layer::Opaque ? 1.0f : (a > 0 ? 1.0f / a : 0.0f);
            for (int k = 0; k < 3; ++k) {
                const float lin = std::clamp(s[k] * inv, 0.0f, 1.0f);
                d[k] = t.to_srgb8[static_cast<size_t>(lin * 65535.0f + 0.5f)];
            }
            if (nc == 4) d[3] = static_cast<uint8_t>(std::clamp(a, 0.0f, 1.0f) * 255.0f + 0.5f);
        }
    }
    return img;
}

}  // namespace

Status writeAtlasPng(const format::Image8& img, const fs::path& path) {
    auto out = OIIO::ImageOutput::create(path.string());
    if (!out) return Status::Io(fmt::format("{}: cannot create a PNG writer", path.string()));
    OIIO::ImageSpec spec(img.width, img.height, img.channels, OIIO::TypeDesc::UINT8);
    // Speed over size (an intermediate: the tiles stage re-encodes): fastest
    // deflate, and one fixed row filter ("up") instead of libpng trying all five per row.
    spec.attribute("png:compressionLevel", 1);
    spec.attribute("png:filter", 0x20);
    spec.attribute("oiio:ColorSpace", "sRGB");
    spec.attribute("oiio:UnassociatedAlpha", 1);  // the bytes are straight alpha already (divided above)
    if (!out->open(path.string(), spec) || !out->write_image(OIIO::TypeDesc::UINT8, img.pixels.data()) || !out->close())
        return Status::Io(fmt::format("{}: cannot write: {}", path.string(), out->geterror()));
    return Status::Ok();
}

namespace {

// Decoded textures kept for the leaves that share them (repeating textures,
// a roof texture used city-wide), least recently used first out, within
// params.cache_mb. A miss decodes outside the lock; two threads missing the
// same texture at once both decode it (rare: leaves are ordered spatially).
class DecodedTextures {
public:
    explicit DecodedTextures(size_t budget_bytes) : budget_(budget_bytes) {}

    std::shared_ptr<const DecodedTexture> get(int32_t index, const std::string& path, std::string* why) {
        {
            std::lock_guard lock(mutex_);
            if (auto it = entries_.find(index); it != entries_.end()) {
                lru_.splice(lru_.begin(), lru_, it->second.position);
                return it->second.texture;
            }
        }
        std::shared_ptr<const DecodedTexture> d = readTextureFile(path, why);
        if (!d) return nullptr;
        std::lock_guard lock(mutex_);
        if (entries_.count(index) || d->bytes() > budget_) return d;
        lru_.push_front(index);
        entries_[index] = {d, lru_.begin()};
        bytes_ += d->bytes();
        while (bytes_ > budget_ && !lru_.empty()) {
            auto it = entries_.find(lru_.back());
            bytes_ -= it->second.texture->bytes();
            entries_.erase(it);
            lru_.pop_back();
        }
        return d;
    }

private:
    struct Entry {
        std::shared_ptr<const DecodedTexture> texture;
        std::list<int32_t>::iterator position;
    };
    size_t budget_;
    size_t bytes_ = 0;
    std::mutex mutex_;
    std::list<int32_t> lru_;
    std::unordered_map<int32_t, Entry> entries_;
};

class Renderer {
public:
    Renderer(const Scene& scene, const AtlasTree& tree, const fs::path& out, const AtlasProgressFn& progress,
             const AtlasImageSink& sink, const GivenHalves* given, bool keep_root)
        : scene_(scene), tree_(tree), out_(out), progress_(progress), sink_(sink), given_(given), keep_root_(keep_root),
          textures_(static_cast<size_t>(tree.params.cache_mb) << 20) {
        countRendered(0);
    }
    Status run(RenderResult* result) {
        Halves root = renderSubtree(0);
        if (keep_root_) result->root_halves = std::move(root);
        result->unreadable_textures = unreadable_;
        result->original_texture_bytes = original_bytes_;
        return first_error_;
    }

private:
    using Halves = std::array<std::optional<Canvas>, kLayerCount>;

    bool isGiven(int32_t id) const { return given_ && given_->nodes.count(id); }

    // The node layers this renderer draws: none at or below a given node.
    void countRendered(int32_t id) {
        if (isGiven(id)) return;
        const AtlasNode& n = tree_.nodes[static_cast<size_t>(id)];
        for (const auto& l : n.layers) total_ += l.present() ? 1 : 0;
        for (int32_t c : n.children)
            if (c >= 0) countRendered(c);
    }

    Halves renderSubtree(int32_t id) {
        if (isGiven(id)) {
            AtlasHalves given;
            if (Status s = given_->load(id, &given); !s.ok()) noteError(s);
            return given;
        }
        const AtlasNode& node = tree_.nodes[id];
        std::array<Halves, 4> child_halves;
        if (!node.leaf()) {
            tbb::task_group group;
            for (int q = 0; q < 4; ++q)
                if (node.children[q] >= 0) group.run([&, q] { child_halves[q] = renderSubtree(node.children[q]); });
            group.wait();
        }
        Halves mine;
        for (int l = 0; l < kLayerCount; ++l) {
            const NodeLayer& layer = node.layers[l];
            if (!layer.present()) continue;
            Canvas canvas(layer.width, layer.height);
            if (node.leaf()) {
                drawLeaf(layer.regions, static_cast<Layer>(l), canvas);
            } else {
                for (const ChildPlacement& p : childPlacements(tree_, id, l)) {
                    int q = 0;
                    while (node.children[q] != p.child) ++q;
                    const auto& h = child_halves[q][l];
                    if (!h) continue;
                    for (int y = 0; y < h->h; ++y)
                        std::copy_n(h->at(0, y), static_cast<size_t>(h->w) * 4, canvas.at(p.x, p.y + y));
                }
            }
            const format::Image8 image = imageOf(canvas, static_cast<Layer>(l));
            if (Status s = sink_ ? sink_(id, static_cast<Layer>(l), image) : writeAtlasPng(image, out_ / layer.atlas_path);
                !s.ok())
                noteError(s);
            if (id != 0 || keep_root_) mine[l] = halve(canvas);
            report();
        }
        return mine;
    }

    // Regions in texture order, so each texture is read and reduced once per
    // leaf and reduction level (walls of one building share both).
    void drawLeaf(const std::vector<PackedRegion>& regions, Layer layer, Canvas& canvas) {
        std::vector<size_t> order(regions.size());
        for (size_t k = 0; k < order.size(); ++k) order[k] = k;
        std::stable_sort(order.begin(), order.end(),
                         [&](size_t a, size_t b) { return regions[a].texture < regions[b].texture; });
        for (size_t begin = 0; begin < order.size();) {
            const int32_t texture = regions[order[begin]].texture;
            size_t end = begin;
            while (end < order.size() && regions[order[end]].texture == texture) ++end;
            drawTexture(texture, layer, std::span(order).subspan(begin, end - begin), regions, canvas);
            begin = end;
        }
    }

    void drawTexture(int32_t texture, Layer layer, std::span<const size_t> which,
                     const std::vector<PackedRegion>& regions, Canvas& canvas) {
        const TextureRef ref = scene_.textures.ref(texture);
        std::string why;
        const std::shared_ptr<const DecodedTexture> decoded = textures_.get(texture, ref.path, &why);
        const bool have_spec = decoded != nullptr;
        const OIIO::ImageSpec spec = have_spec ? decoded->spec : OIIO::ImageSpec();
        // The least reduction any region of this texture needs is applied while
        // converting (one pass over the 8-bit pixels); the rest per region.
        std::pair<int, int> base{99, 99};
        if (have_spec)
            for (size_t k : which) {
                const auto lv = reductionLevels(regions[k], spec.width, spec.height);
                base = {std::min(base.first, lv.first), std::min(base.second, lv.second)};
            }
        Image img;
        if (!have_spec || !load(texture, *decoded, layer, &base, &img)) {
            {
                std::lock_guard lock(mutex_);
                unreadable_.insert(texture);
            }
            // Mid grey (sRGB 0.5), opaque: visible as "missing", never black holes.
            for (size_t k : which) {
                const PackedRegion& r = regions[k];
                for (int y = r.y; y < r.y + r.h; ++y)
                    for (int x = r.x; x < r.x + r.w; ++x) {
                        float* d = canvas.at(x, y);
                        d[0] = d[1] = d[2] = 0.2140f, d[3] = 1.0f;
                    }
            }
            return;
        }
        std::map<std::pair<int, int>, Image> levels;
        for (size_t k : which) {
            const PackedRegion& r = regions[k];
            const auto key = reductionLevels(r, spec.width, spec.height);
            const std::pair<int, int> more{key.first - base.first, key.second - base.second};
            const Image* src = &img;
            if (more != std::pair{0, 0}) {
                auto it = levels.find(more);
                if (it == levels.end()) it = levels.emplace(more, reduced(img, more.first, more.second)).first;
                src = &it->second;
            }
            resampleRegion(*src, r, ref.wrap, tree_.params.filter, canvas);
        }
    }

    // Converts a decoded texture into linear premultiplied floats,
    // box-reduced by 2^levels on each axis on the way (levels are lowered
    // until they divide the size, so the reduction is exact and periodic).
    bool load(int32_t index, const DecodedTexture& decoded, Layer layer, std::pair<int, int>* levels, Image* img) {
        const OIIO::ImageSpec& spec = decoded.spec;
        const int nc = decoded.channels;
        const size_t n = static_cast<size_t>(spec.width) * spec.height;
        const bool eight = !decoded.raw8.empty();
        const std::vector<uint8_t>& raw8 = decoded.raw8;
        const std::vector<uint16_t>& raw16 = decoded.raw16;
        {
            std::lock_guard lock(mutex_);
            if (counted_.insert(index).second) original_bytes_ += static_cast<uint64_t>(n) * nc;
        }
        auto& [lu, lv] = *levels;
        while (lu > 0 && spec.width % (1 << lu) != 0) --lu;
        while (lv > 0 && spec.height % (1 << lv) != 0) --lv;
        const int fx = 1 << lu, fy = 1 << lv;
        const auto& lin = tables().to_linear;
        img->w = spec.width / fx, img->h = spec.height / fy;
        img->px.assign(static_cast<size_t>(img->w) * img->h * 4, 0.0f);
        const bool has_alpha = layer == Layer::Alpha && (nc == 2 || nc == 4);
        const float scale = 1.0f / static_cast<float>(fx * fy);
        for (int y = 0; y < spec.height; ++y) {
            float* out_row = img->at(0, y / fy);
            for (int x = 0; x < spec.width; ++x) {
                const size_t p = static_cast<size_t>(y) * spec.width + x;
                uint16_t v[4];
                for (int c = 0; c < nc; ++c) v[c] = eight ? static_cast<uint16_t>(raw8[p * nc + c] * 257) : raw16[p * nc + c];
                float* d = out_row + (x / fx) * 4;
                const float a = has_alpha ? v[nc - 1] / 65535.0f : 1.0f;
                if (nc >= 3) {
                    for (int c = 0; c < 3; ++c) d[c] += scale * lin[v[c]] * a;
                } else {
                    const float g = scale * lin[v[0]] * a;
                    d[0] += g, d[1] += g, d[2] += g;
                }
                d[3] += scale * a;
            }
        }
        return true;
    }

    void noteError(const Status& s) {
        std::lock_guard lock(mutex_);
        if (first_error_.ok()) first_error_ = s;
    }

    void report() {
        const uint64_t done = ++done_;
        if (!progress_) return;
        std::lock_guard lock(mutex_);
        progress_("atlas images", done, total_);
    }

    const Scene& scene_;
    const AtlasTree& tree_;
    fs::path out_;
    const AtlasProgressFn& progress_;
    const AtlasImageSink& sink_;
    const GivenHalves* given_;
    bool keep_root_;
    DecodedTextures textures_;
    std::mutex mutex_;
    std::set<int32_t> unreadable_, counted_;
    uint64_t original_bytes_ = 0;
    Status first_error_;
    std::atomic<uint64_t> done_{0};
    uint64_t total_ = 0;
};

}  // namespace

Status writeFloatImage(const fs::path& path, int w, int h, const std::vector<float>& values) {
    std::ofstream f(path, std::ios::binary);
    const int32_t size[2] = {w, h};
    f.write(reinterpret_cast<const char*>(size), sizeof size);
    f.write(reinterpret_cast<const char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(float)));
    f.close();
    if (!f) return Status::Io(fmt::format("{}: cannot write", path.string()));
    return Status::Ok();
}

Status readFloatImage(const fs::path& path, int channels, bool allow_empty, const char* what, int* w, int* h,
                      std::vector<float>* values) {
    std::ifstream f(path, std::ios::binary);
    int32_t size[2] = {0, 0};
    f.read(reinterpret_cast<char*>(size), sizeof size);
    const int32_t least = allow_empty ? 0 : 1;
    if (!f || size[0] < least || size[1] < least || size[0] > 65536 || size[1] > 65536)
        return Status::Io(fmt::format("{}: not {}", path.string(), what));
    *w = size[0], *h = size[1];
    values->assign(static_cast<size_t>(size[0]) * static_cast<size_t>(size[1]) * static_cast<size_t>(channels), 0.0f);
    f.read(reinterpret_cast<char*>(values->data()), static_cast<std::streamsize>(values->size() * sizeof(float)));
    if (!f || f.peek() != EOF) return Status::Io(fmt::format("{}: truncated or too long", path.string()));
    return Status::Ok();
}

Status writeCanvas(const AtlasCanvas& c, const fs::path& path) { return writeFloatImage(path, c.w, c.h, c.px); }

Status readCanvas(const fs::path& path, AtlasCanvas* c) {
    *c = AtlasCanvas{};
    return readFloatImage(path, 4, false, "an atlas canvas", &c->w, &c->h, &c->px);
}

Status renderAtlases(const Scene& scene, const AtlasTree& tree, const fs::path& output_dir,
                     const AtlasProgressFn& progress, RenderResult* result, const AtlasImageSink& sink,
                     const GivenHalves* given, bool keep_root_halves) {
    if (tree.nodes.empty()) return Status::Ok();
    for (Layer l : {Layer::Opaque, Layer::Alpha}) {
        std::error_code ec;
        fs::create_directories(output_dir / "atlas" / layerName(l), ec);
        if (ec) return Status::Io(fmt::format("{}: cannot create: {}", (output_dir / "atlas").string(), ec.message()));
    }
    Renderer renderer(scene, tree, output_dir, progress, sink, given, keep_root_halves);
    return renderer.run(result);
}

}  // namespace cityatlas::atlas
