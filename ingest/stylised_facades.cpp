// SPDX-License-Identifier: GPL-3.0-or-later
// Stylised facades: the reduction of a photo facade to colours and a window
// grid, and the clean facade drawn from it (see the header).

#include "ingest/stylised_facades.h"

#include <algorithm>
#include <cstddef>
#include <cmath>
#include <numeric>

#include "core/srgb.h"

namespace cityatlas {
namespace {

// The analysis works on images of at most this many pixels a side: larger
// ones are box-averaged by an integer factor first (windows stay far larger
// than a pixel) and the grid is scaled back.
constexpr int kMaxAnalysedSide = 1024;
// The least distance beyond the facade's peak (sRGB-encoded, 0..1) that
// counts as far: a plain wall's noise stays inside.
constexpr double kMinContrast = 16.0 / 255.0;

// The same, for the analysis's per-pixel distances: a table, interpolated
// (within 2e-4 of the curve: far below the distances' cuts), as a pow per
// channel and pixel was most of the analysis' time.
float srgbFromLinearFast(float l) {
    constexpr int kSteps = 4096;
    static const std::array<float, kSteps + 2> table = [] {
        std::array<float, kSteps + 2> t{};
        for (int i = 0; i <= kSteps + 1; ++i) t[static_cast<size_t>(i)] = static_cast<float>(srgbFromLinear(std::min(1.0, static_cast<double>(i) / kSteps)));
        return t;
    }();
    const float x = std::clamp(l, 0.0f, 1.0f) * kSteps;
    const auto i = static_cast<size_t>(x);
    return table[i] + (x - static_cast<float>(i)) * (table[i + 1] - table[i]);
}
uint8_t srgbByte(double linear) {
    return static_cast<uint8_t>(std::lround(std::clamp(srgbFromLinear(std::clamp(linear, 0.0, 1.0)), 0.0, 1.0) * 255.0));
}

// Linear RGBA planes of an image, averaged down by `factor` in each direction.
struct LinearImage {
    int width = 0, height = 0;
    std::vector<std::array<float, 4>> px;  // linear r, g, b; alpha 0..1
};

LinearImage linearImage(const synth::Image8& image, int factor) {
    static const std::array<float, 256> lut = [] {
        std::array<float, 256> t{};
        for (int i = 0; i < 256; ++i) t[static_cast<size_t>(i)] = static_cast<float>(linearFromSrgb(i / 255.0));
        return t;
    }();
    LinearImage out;
    out.width = std::max(1, image.width / factor);
    out.height = std::max(1, image.height / factor);
    out.px.assign(static_cast<size_t>(out.width) * out.height, {0, 0, 0, 0});
    const int ch = image.channels;
    const float weight = 1.0f / static_cast<float>(factor * factor);
    for (int y = 0; y < out.height * factor && y < image.height; ++y)
        for (int x = 0; x < out.width * factor && x < image.width; ++x) {
            const uint8_t* p = image.pixels.data() + (static_cast<size_t>(y) * image.width + x) * ch;
            const bool grey = ch < 3;
            const float a = ch == 2 ? p[1] / 255.0f : ch == 4 ? p[3] / 255.0f : 1.0f;
            std::array<float, 4>& o = out.px[static_cast<size_t>(y / factor) * out.width + x / factor];
            o[0] += weight * lut[p[0]];
            o[1] += weight * lut[grey ? p[0] : p[1]];
            o[2] += weight * lut[grey ? p[0] : p[2]];
            o[3] += weight * a;
        }
    return out;
}

// A separable box blur of radius rx across and ry down; at the edges, the mean of the part of
// the box inside the image (clamping would weigh an edge pixel r times).
std::vector<float> boxBlur(const std::vector<float>& in, int w, int h, int rx, int ry) {
    std::vector<float> tmp(in.size()), out(in.size());
    std::vector<double> prefix(static_cast<size_t>(w) + 1);
    for (int y = 0; y < h; ++y) {  // across: prefix sums of each row
        const float* src = in.data() + static_cast<std::ptrdiff_t>(y) * w;
        float* dst = tmp.data() + static_cast<std::ptrdiff_t>(y) * w;
        for (int x = 0; x < w; ++x) prefix[static_cast<size_t>(x) + 1] = prefix[static_cast<size_t>(x)] + src[x];
        for (int x = 0; x < w; ++x) {
            const int a = std::max(0, x - rx), b = std::min(w, x + rx + 1);
            dst[x] = static_cast<float>((prefix[static_cast<size_t>(b)] - prefix[static_cast<size_t>(a)]) / (b - a));
        }
    }
    // Down: a running sum of the rows in reach, row by row (memory order).
    std::vector<double> sum(static_cast<size_t>(w), 0);
    auto addRow = [&](int y, double sign) {
        const float* row = tmp.data() + static_cast<std::ptrdiff_t>(y) * w;
        for (int x = 0; x < w; ++x) sum[static_cast<size_t>(x)] += sign * row[x];
    };
    for (int y = 0; y < std::min(h, ry); ++y) addRow(y, 1);
    for (int y = 0; y < h; ++y) {
        if (y + ry < h) addRow(y + ry, 1);
        if (y - ry - 1 >= 0) addRow(y - ry - 1, -1);
        const int count = std::min(h, y + ry + 1) - std::max(0, y - ry);
        float* dst = out.data() + static_cast<std::ptrdiff_t>(y) * w;
        for (int x = 0; x < w; ++x) dst[x] = static_cast<float>(sum[static_cast<size_t>(x)] / count);
    }
    return out;
}

// Where the facade's distances end (see step 2 of analyseFacade): the
// histogram's main peak plus three of its half widths, or the valley before
// a second peak if that comes first.
double facadeCut(const std::vector<float>& distance) {
    constexpr int kBins = 128;
    std::vector<double> raw(kBins, 0), count(kBins, 0);
    for (float v : distance) raw[static_cast<size_t>(std::clamp(static_cast<int>(v * kBins), 0, kBins - 1))] += 1;
    for (int b = 0; b < kBins; ++b)  // smoothed over 5 bins, so a wide peak wins over a narrow one
        for (int k = std::max(0, b - 2); k <= std::min(kBins - 1, b + 2); ++k) count[static_cast<size_t>(b)] += raw[static_cast<size_t>(k)];
    const int peak = static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
    int below = peak;
    while (below > 0 && count[static_cast<size_t>(below)] * 2 > count[static_cast<size_t>(peak)]) --below;
    int above = peak;
    while (above + 1 < kBins && count[static_cast<size_t>(above)] * 2 > count[static_cast<size_t>(peak)]) ++above;
    // The near side, unless the peak sits against zero (a plain wall).
    const int half_width = std::max(1, below > 0 ? peak - below : above - peak);
    int cut = peak + 3 * half_width;
    // Windows close to the wall's tone make a second peak on the first one's
    // shoulder: then the valley between them, where it comes first.
    for (int b = above + 1; b + 1 < kBins && b < cut; ++b) {
        const double v = count[static_cast<size_t>(b)];
        if (v > count[static_cast<size_t>(b - 1)] || v > count[static_cast<size_t>(b + 1)]) continue;  // not a minimum
        const double rise = *std::max_element(count.begin() + b, count.end());
        if (rise >= 2 * v && rise >= 0.05 * count[static_cast<size_t>(peak)]) {
            cut = b;
            break;
        }
    }
    return std::max((cut + 0.5) / kBins, (peak + 0.5) / kBins + kMinContrast);
}

// The period of a profile from its autocorrelation: with a hint (the
// windows' spacing), the highest autocorrelation within a quarter of it;
// without, the first lag, after the autocorrelation first turns negative,
// at a local maximum reaching at least 80 % of the highest such maximum
// (and 0.3); 0 when there is none.
int periodOf(const std::vector<double>& p, int hint) {
    const int n = static_cast<int>(p.size());
    const std::vector<float> smooth_f =
        boxBlur(std::vector<float>(p.begin(), p.end()), n, 1, std::max(1, n / 128), 0);  // thin dips, non-integer periods
    const std::vector<double> smooth(smooth_f.begin(), smooth_f.end());
    const double mean = std::accumulate(smooth.begin(), smooth.end(), 0.0) / std::max(1, n);
    std::vector<double> d(p.size());
    double var = 0;
    for (int i = 0; i < n; ++i) d[static_cast<size_t>(i)] = smooth[static_cast<size_t>(i)] - mean, var += d[static_cast<size_t>(i)] * d[static_cast<size_t>(i)];
    if (var <= 1e-12 * n) return 0;
    const int max_lag = n * 3 / 4;
    std::vector<double> a(static_cast<size_t>(max_lag + 2), 0);
    for (int lag = 1; lag <= max_lag + 1 && lag < n; ++lag) {
        double s = 0;
        for (int i = 0; i + lag < n; ++i) s += d[static_cast<size_t>(i)] * d[static_cast<size_t>(i + lag)];
        a[static_cast<size_t>(lag)] = s / var * n / (n - lag);
    }
    if (hint > 0) {  // the autocorrelation's highest point within a quarter of the hint
        int best_lag = 0;
        for (int lag = std::max(2, hint * 3 / 4); lag <= std::min(max_lag, hint * 5 / 4); ++lag)
            if (best_lag == 0 || a[static_cast<size_t>(lag)] > a[static_cast<size_t>(best_lag)]) best_lag = lag;
        return best_lag > 0 ? best_lag : hint;
    }
    int first_negative = 1;
    while (first_negative <= max_lag && a[static_cast<size_t>(first_negative)] >= 0) ++first_negative;
    std::vector<int> peaks;
    double best = 0.3;
    for (int lag = first_negative + 1; lag <= max_lag; ++lag) {
        const double v = a[static_cast<size_t>(lag)];
        if (v >= a[static_cast<size_t>(lag - 1)] && v > a[static_cast<size_t>(lag + 1)] && v >= 0.3) {
            peaks.push_back(lag);
            best = std::max(best, v);
        }
    }
    for (int lag : peaks)
        if (a[static_cast<size_t>(lag)] >= 0.8 * best) return lag;
    return 0;
}

// The runs [start, end) of a profile at or above a level, at least 2 long.
std::vector<std::pair<int, int>> runsAbove(const std::vector<double>& profile, double level) {
    std::vector<std::pair<int, int>> runs;
    const int n = static_cast<int>(profile.size());
    for (int i = 0; i < n;) {
        if (profile[static_cast<size_t>(i)] < level) { ++i; continue; }
        int j = i;
        while (j < n && profile[static_cast<size_t>(j)] >= level) ++j;
        if (j - i >= 2) runs.emplace_back(i, j);
        i = j;
    }
    return runs;
}

// One axis of the grid from the window fraction of each column (row): the
// runs above a quarter of the profile's typical height; where they repeat,
// the cells of one regular grid instead, each present when a run above a
// twelfth (a column with some windows lit, a narrow door alone) covers at least
// half of it. A run confirms as many cells as the periods it spans, so a
// taller ground-floor window is one row and two merged storeys are two.
WindowAxis windowAxis(const std::vector<double>& profile) {
    WindowAxis axis;
    const int n = static_cast<int>(profile.size());
    // The profile's typical height where it shows windows (its 80th
    // percentile there), not its maximum, which one wide sign or a partly
    // detected band would set.
    std::vector<double> shown;
    for (double v : profile)
        if (v >= 0.02) shown.push_back(v);
    if (shown.empty()) return axis;
    std::nth_element(shown.begin(), shown.begin() + static_cast<std::ptrdiff_t>(shown.size() * 4 / 5), shown.end());
    const double peak = shown[shown.size() * 4 / 5];
    if (peak < 0.05) return axis;
    const std::vector<std::pair<int, int>> runs = runsAbove(profile, peak / 4);
    if (runs.empty()) return axis;
    std::vector<int> lengths;
    for (const auto& [s, e] : runs) lengths.push_back(e - s);
    std::nth_element(lengths.begin(), lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2), lengths.end());
    axis.length = lengths[lengths.size() / 2];
    // The spacing of the windows: the median distance between consecutive
    // runs of at least half the typical length (not fragments of one).
    std::vector<int> spacing;
    int last_start = -1;
    for (const auto& [s, e] : runs) {
        if ((e - s) * 2 < axis.length) continue;
        if (last_start >= 0) spacing.push_back(s - last_start);
        last_start = s;
    }
    int hint = 0;
    if (!spacing.empty()) {
        std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(spacing.size() / 2), spacing.end());
        hint = spacing[spacing.size() / 2];
    }
    const int period = runs.size() >= 2 ? periodOf(profile, hint) : 0;
    if (period <= axis.length) {
        for (const auto& r : runs) axis.start.push_back(r.first);
        return axis;
    }
    // The grid through the typical runs' starts: each run's index on the
    // grid from the period, then a least-squares line through (index,
    // start), so a period of a fraction of a pixel more or less does not
    // drift over a tall facade.
    // Runs off the grid by over a quarter period, or of another length than
    // the typical one by half (a sign, a door), stay out of the fit.
    int first = runs.front().first;
    for (const auto& [s, e] : runs)
        if (std::abs((e - s) - axis.length) * 4 <= axis.length) { first = s; break; }
    std::vector<std::pair<double, double>> fit;  // (index, start)
    for (const auto& [s, e] : runs) {
        if (std::abs((e - s) - axis.length) * 2 > axis.length) continue;
        const double k = std::round(static_cast<double>(s - first) / period);
        if (std::abs(s - first - k * period) * 4 <= period) fit.emplace_back(k, s);
    }
    std::sort(fit.begin(), fit.end());
    double pitch = period, phase = first;
    if (fit.size() >= 2 && fit.back().first > fit.front().first) {
        double mk = 0, ms = 0;
        for (const auto& [k, s] : fit) mk += k, ms += s;
        mk /= static_cast<double>(fit.size()), ms /= static_cast<double>(fit.size());
        double skk = 0, sks = 0;
        for (const auto& [k, s] : fit) skk += (k - mk) * (k - mk), sks += (k - mk) * (s - ms);
        pitch = sks / skk;
        phase = ms - pitch * mk;
    }
    axis.period = pitch;
    std::vector<int> cells;
    for (double k = std::floor(-phase / pitch) - 1; phase + k * pitch < n; k += 1) cells.push_back(static_cast<int>(std::lround(phase + k * pitch)));
    std::vector<uint8_t> present(cells.size(), 0);
    for (const auto& [rs, re] : runsAbove(profile, peak / 12)) {
        // The cells this run covers, most covered first; it confirms as many
        // as the periods it spans (at least one), each if at least half covered.
        std::vector<std::pair<int, size_t>> cover;
        for (size_t c = 0; c < cells.size(); ++c)
            cover.emplace_back(std::min(re, cells[c] + axis.length) - std::max(rs, cells[c]), c);
        std::sort(cover.begin(), cover.end(), [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
        const int spans = std::max(1, static_cast<int>(std::lround((re - rs) / pitch)));
        for (int k = 0; k < spans && k < static_cast<int>(cover.size()); ++k)
            if (cover[static_cast<size_t>(k)].first * 2 >= axis.length) present[cover[static_cast<size_t>(k)].second] = 1;
    }
    for (size_t c = 0; c < cells.size(); ++c)
        if (present[c]) axis.start.push_back(cells[c]);
    return axis;
}

// Removes the 4-connected blobs of `mask` that are not windows (see
// analyseFacade): over four times the median blob's area and larger than
// its box both ways (1.25 times: a ground floor's
// taller windows and doors are typical too), or under an eighth of its area.
void keepTypicalBlobs(int w, int h, std::vector<uint8_t>* mask) {
    struct Blob {
        size_t area = 0;
        int x0, y0, x1, y1;
    };
    std::vector<int32_t> label(mask->size(), -1);
    std::vector<Blob> blobs;
    std::vector<size_t> stack;
    for (size_t start = 0; start < mask->size(); ++start) {
        if (!(*mask)[start] || label[start] >= 0) continue;
        const auto id = static_cast<int32_t>(blobs.size());
        blobs.push_back({0, w, h, -1, -1});
        label[start] = id;
        stack.push_back(start);
        while (!stack.empty()) {
            const size_t i = stack.back();
            stack.pop_back();
            const int x = static_cast<int>(i % static_cast<size_t>(w)), y = static_cast<int>(i / static_cast<size_t>(w));
            Blob& b = blobs.back();
            ++b.area;
            b.x0 = std::min(b.x0, x), b.y0 = std::min(b.y0, y), b.x1 = std::max(b.x1, x), b.y1 = std::max(b.y1, y);
            const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
            for (int k = 0; k < 4; ++k) {
                if (nx[k] < 0 || ny[k] < 0 || nx[k] >= w || ny[k] >= h) continue;
                const size_t j = static_cast<size_t>(ny[k]) * w + nx[k];
                if ((*mask)[j] && label[j] < 0) label[j] = id, stack.push_back(j);
            }
        }
    }
    if (blobs.empty()) return;
    // Medians weighted by area (the blob the median window pixel lies in,
    // so that specks of noise do not count), the largest blob left out (so
    // that one big sign does not set them).
    size_t largest = 0;
    for (size_t k = 1; k < blobs.size(); ++k)
        if (blobs[k].area > blobs[largest].area) largest = k;
    auto median = [&](auto value) {
        std::vector<std::pair<double, size_t>> v;
        size_t total = 0;
        for (size_t k = 0; k < blobs.size(); ++k)
            if (k != largest || blobs.size() == 1) v.emplace_back(value(blobs[k]), blobs[k].area), total += blobs[k].area;
        std::sort(v.begin(), v.end());
        size_t seen = 0;
        for (const auto& [x, a] : v)
            if ((seen += a) * 2 >= total) return x;
        return v.back().first;
    };
    const double area = median([](const Blob& b) { return static_cast<double>(b.area); });
    const double width = median([](const Blob& b) { return b.x1 - b.x0 + 1.0; });
    const double height = median([](const Blob& b) { return b.y1 - b.y0 + 1.0; });
    std::vector<uint8_t> keep(blobs.size());
    for (size_t k = 0; k < blobs.size(); ++k) {
        const Blob& b = blobs[k];
        const bool large = b.x1 - b.x0 + 1 > 1.25 * width && b.y1 - b.y0 + 1 > 1.25 * height &&
                           static_cast<double>(b.area) > 4 * area;
        keep[k] = !large && static_cast<double>(b.area) * 8 >= area;
    }
    for (size_t i = 0; i < mask->size(); ++i)
        if (label[i] >= 0 && !keep[static_cast<size_t>(label[i])]) (*mask)[i] = 0;
}

// Shrinks every cell of an axis alike to where a profile, folded over the
// cells (and half a cell around them), is above halfway between its lowest
// and its peak inside the cell.
void tighten(const std::vector<double>& profile, WindowAxis* axis) {
    const int n = static_cast<int>(profile.size()), margin = axis->length / 2 + 2, span = axis->length + 2 * margin;
    std::vector<double> sum(static_cast<size_t>(span), 0), count(static_cast<size_t>(span), 0);
    for (const int s : axis->start)
        for (int i = 0; i < span; ++i)
            if (const int at = s - margin + i; at >= 0 && at < n)
                sum[static_cast<size_t>(i)] += profile[static_cast<size_t>(at)], count[static_cast<size_t>(i)] += 1;
    std::vector<double> mean(static_cast<size_t>(span), 0);
    for (size_t i = 0; i < mean.size(); ++i) mean[i] = count[i] > 0 ? sum[i] / count[i] : 0;
    // Only inside the cell as found (the blur only widens), and only where
    // that keeps most of it (a frame's line is not the window).
    const auto first = mean.begin() + margin, last = first + axis->length;
    const auto top = std::max_element(first, last);
    const double base = *std::min_element(mean.begin(), mean.end()), level = (*top + base) / 2;
    if (*top <= base) return;
    int a = static_cast<int>(top - mean.begin()), b = a + 1;
    while (a > margin && mean[static_cast<size_t>(a - 1)] >= level) --a;
    while (b < margin + axis->length && mean[static_cast<size_t>(b)] >= level) ++b;
    if ((b - a) * 5 < axis->length * 3) return;
    for (int& s : axis->start) s += a - margin;
    axis->length = b - a;
}

bool inCell(const WindowAxis& axis, int i) {
    for (int s : axis.start)
        if (i >= s && i < s + axis.length) return true;
    return false;
}

WindowAxis scaled(WindowAxis axis, int factor) {
    for (int& s : axis.start) s *= factor;
    axis.length *= factor;
    axis.period *= factor;
    return axis;
}

// Steps 1 and 2 of analyseFacade: which pixels are far from the wall, which
// of them are windows, which rows are trim bands.
struct FacadeMasks {
    int radius = 0;                  ///< the blur's, pixels
    std::vector<float> raw_distance; ///< each pixel's distance from the facade tone, unblurred
    double cut = 0;                  ///< where the (blurred) distance leaves the facade
    std::vector<uint8_t> far;        ///< either measure beyond its cut
    std::vector<uint8_t> window;     ///< far, at half the blur, outside trim bands, in typical blobs
    std::vector<uint8_t> band;       ///< per row: a trim band across the facade
};

// Each pixel's distance from the median colour of the planes (sRGB-encoded
// values: distances then follow what the eye sees).
std::vector<float> distanceFromMedian(const std::array<std::vector<float>, 3>& encoded) {
    const size_t n = encoded[0].size();
    std::array<float, 3> median{};
    for (size_t c = 0; c < 3; ++c) {
        std::vector<float> v = encoded[c];
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(n / 2), v.end());
        median[c] = v[n / 2];
    }
    std::vector<float> d(n);
    for (size_t i = 0; i < n; ++i) {
        double d2 = 0;
        for (size_t c = 0; c < 3; ++c) d2 += (encoded[c][i] - median[c]) * (encoded[c][i] - median[c]);
        d[i] = static_cast<float>(std::min(1.0, std::sqrt(d2)));
    }
    return d;
}

// The image's colour planes, box-blurred in linear light by r (0: not
// blurred), sRGB-encoded.
std::array<std::vector<float>, 3> encodedPlanes(const LinearImage& lin, int r) {
    std::array<std::vector<float>, 3> planes;
    for (size_t c = 0; c < 3; ++c) {
        planes[c].resize(lin.px.size());
        for (size_t i = 0; i < lin.px.size(); ++i) planes[c][i] = lin.px[i][c];
        if (r > 0) planes[c] = boxBlur(planes[c], lin.width, lin.height, r, r);
        for (float& v : planes[c]) v = srgbFromLinearFast(v);
    }
    return planes;
}

FacadeMasks farFromWall(const LinearImage& lin) {
    const int w = lin.width, h = lin.height;
    const size_t n = lin.px.size();
    FacadeMasks m;
    // 1. Each pixel's distance from the facade tone, box-blurred over about
    // 1/32 of the facade: a wall's fine pattern (bricks and their joints)
    // averages out near the tone, while a window's glass and frame, both far
    // from it, stay far together. And the distance of the blurred colour
    // from its median: there the joints blend into the wall's mean colour,
    // so a window of another hue that is no farther from the tone than the
    // joints are (green glass on brick with light joints) still stands out,
    // where a window whose glass and frame average to the wall's colour does
    // not.
    m.radius = std::min(w, h) / 64;
    m.raw_distance = distanceFromMedian(encodedPlanes(lin, 0));
    const std::vector<float> distance = boxBlur(m.raw_distance, w, h, m.radius, m.radius);
    const std::vector<float> colour_distance = distanceFromMedian(encodedPlanes(lin, 2 * m.radius));

    // 2. The facade is each histogram's main peak; windows (with their
    // frames and sills), trim, doors and signs lie beyond its cut.
    m.cut = facadeCut(distance);
    const double colour_cut = facadeCut(colour_distance);
    m.far.assign(n, 0);
    for (size_t i = 0; i < n; ++i) m.far[i] = distance[i] >= m.cut || colour_distance[i] >= colour_cut;
    // A band across (nearly) the whole width is trim (a cornice, a string
    // course, a plinth), part of the facade and not a row of windows; so are
    // the rows the blur spread it over.
    m.band.assign(static_cast<size_t>(h), 0);
    std::vector<uint8_t> band_reach(static_cast<size_t>(h), 0);
    for (int y = 0; y < h; ++y) {
        const uint8_t* row = m.far.data() + static_cast<size_t>(y) * w;
        if (std::count(row, row + w, uint8_t{1}) * 10 < w * 9) continue;
        m.band[static_cast<size_t>(y)] = 1;
        for (int b = std::max(0, y - m.radius); b <= std::min(h - 1, y + m.radius); ++b) band_reach[static_cast<size_t>(b)] = 1;
    }
    // The windows from half the blur: the full blur's halos would join
    // windows closer than its width into one blob.
    const std::vector<float> fine = boxBlur(m.raw_distance, w, h, m.radius / 2, m.radius / 2);
    const std::vector<float> colour_fine = distanceFromMedian(encodedPlanes(lin, m.radius));
    m.window.assign(n, 0);
    for (size_t i = 0; i < n; ++i) m.window[i] = m.far[i] && (fine[i] >= m.cut || colour_fine[i] >= colour_cut);
    for (int y = 0; y < h; ++y)
        if (band_reach[static_cast<size_t>(y)]) std::fill_n(m.window.begin() + static_cast<std::ptrdiff_t>(y) * w, w, uint8_t{0});
    // Windows are many blobs of one size: a blob larger than the typical one
    // both ways (a sign, a shop front, a number plate) or much smaller
    // (noise) is not one. Merged windows (a column joined by its sills) and
    // doors are larger in one direction only.
    keepTypicalBlobs(w, h, &m.window);
    return m;
}

// Step 3: the grid, from each column's and each row's window fraction; the
// blur widened each window by up to its reach, so the cells' extent comes
// again from the unblurred distances, inside the other axis' cells.
void findGrid(const LinearImage& lin, const FacadeMasks& m, WindowAxis* columns, WindowAxis* rows) {
    const int w = lin.width, h = lin.height;
    std::vector<double> column_share(static_cast<size_t>(w), 0), row_share(static_cast<size_t>(h), 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            if (m.window[static_cast<size_t>(y) * w + x])
                column_share[static_cast<size_t>(x)] += 1.0 / h, row_share[static_cast<size_t>(y)] += 1.0 / w;
    *columns = windowAxis(column_share), *rows = windowAxis(row_share);
    if (columns->start.empty() || rows->start.empty()) {
        *columns = *rows = {};
        return;
    }
    std::vector<double> raw_columns(static_cast<size_t>(w), 0), raw_rows(static_cast<size_t>(h), 0);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (m.raw_distance[static_cast<size_t>(y) * w + x] < m.cut) continue;
            if (inCell(*rows, y)) raw_columns[static_cast<size_t>(x)] += 1;
            if (inCell(*columns, x)) raw_rows[static_cast<size_t>(y)] += 1;
        }
    tighten(raw_columns, columns);
    tighten(raw_rows, rows);
}

// Step 4: the facade's colour, row by row, as the facade's horizontal parts
// (trim bands, rows of windows) take their own share of it: each row's
// sample (all of a band, which has no windows; elsewhere what is neither
// far, nor near a window, where the blur mixes wall and frame, nor in a
// cell, where a lit window can be as near the wall's tone) weighted by
// the row's facade area (all but the pixels far both blurred and
// unblurred: a blurred window reaches over the wall around it). The
// windows' colour from their pixels inside the grid's cells. The grid goes
// into the summary only if it holds window pixels.
void averageColours(const LinearImage& lin, const FacadeMasks& m, const WindowAxis& columns, const WindowAxis& rows,
                    FacadeSummary* summary) {
    const int w = lin.width, h = lin.height;
    std::vector<float> window_f(m.window.begin(), m.window.end());
    const std::vector<float> near_window = boxBlur(window_f, w, h, m.radius, m.radius);
    struct Mean {
        std::array<double, 4> sum{0, 0, 0, 0};
        double samples = 0;
        void add(const std::array<float, 4>& p) {
            for (size_t c = 0; c < 4; ++c) sum[c] += p[c];
            samples += 1;
        }
    };
    Mean wall, windows;
    std::vector<Mean> row_mean(static_cast<size_t>(h));
    std::vector<double> row_area(static_cast<size_t>(h), 0);
    for (int y = 0; y < h; ++y) {
        const bool in_band = m.band[static_cast<size_t>(y)] != 0;
        for (int x = 0; x < w; ++x) {
            const size_t i = static_cast<size_t>(y) * w + x;
            if (in_band || !m.far[i] || m.raw_distance[i] < m.cut) row_area[static_cast<size_t>(y)] += 1;
            if (in_band || (!m.far[i] && near_window[i] < 1e-4f && !(inCell(rows, y) && inCell(columns, x)))) {
                row_mean[static_cast<size_t>(y)].add(lin.px[i]);
                wall.add(lin.px[i]);
            }
            if (m.window[i] && inCell(rows, y) && inCell(columns, x)) windows.add(lin.px[i]);
        }
    }
    std::array<double, 4> facade{0, 0, 0, 0};
    double area = 0;
    for (size_t y = 0; y < static_cast<size_t>(h) && wall.samples > 0; ++y) {
        const Mean& mean = row_mean[y].samples > 0 ? row_mean[y] : wall;  // a row all windows: the wall's mean
        for (size_t c = 0; c < 4; ++c) facade[c] += row_area[y] * mean.sum[c] / mean.samples;
        area += row_area[y];
    }
    if (area == 0) {  // nothing but windows: the mean of everything
        for (const auto& p : lin.px)
            for (size_t c = 0; c < 4; ++c) facade[c] += p[c];
        area = static_cast<double>(lin.px.size());
    }
    auto colour = [](const std::array<double, 4>& s, double c, std::array<uint8_t, 3>* rgb, uint8_t* alpha) {
        for (size_t k = 0; k < 3; ++k) (*rgb)[k] = srgbByte(s[k] / c);
        *alpha = static_cast<uint8_t>(std::lround(std::clamp(s[3] / c, 0.0, 1.0) * 255));
    };
    colour(facade, area, &summary->facade_rgb, &summary->facade_alpha);
    if (windows.samples > 0) {
        colour(windows.sum, windows.samples, &summary->window_rgb, &summary->window_alpha);
        summary->columns = columns;
        summary->rows = rows;
    } else {
        summary->window_rgb = summary->facade_rgb;
    }
}

}  // namespace

FacadeSummary analyseFacade(const synth::Image8& image) {
    FacadeSummary summary;
    if (image.width <= 0 || image.height <= 0 || image.channels < 1) return summary;
    const int factor = std::max(1, (std::max(image.width, image.height) + kMaxAnalysedSide - 1) / kMaxAnalysedSide);
    const LinearImage lin = linearImage(image, factor);
    const FacadeMasks masks = farFromWall(lin);
    WindowAxis columns, rows;
    findGrid(lin, masks, &columns, &rows);
    averageColours(lin, masks, columns, rows, &summary);
    if (!summary.columns.start.empty()) {
        summary.columns = scaled(summary.columns, factor);
        summary.rows = scaled(summary.rows, factor);
    }
    return summary;
}

bool uprightOnWall(const Triangle& t, const TextureInfo& texture) {
    const Vec3d e1 = t.position_local[1] - t.position_local[0], e2 = t.position_local[2] - t.position_local[0];
    const Vec2d d1{t.uv[1].x - t.uv[0].x, t.uv[1].y - t.uv[0].y}, d2{t.uv[2].x - t.uv[0].x, t.uv[2].y - t.uv[0].y};
    const double det = d1.x * d2.y - d2.x * d1.y;
    if (det == 0 || texture.width_px <= 0 || texture.height_px <= 0) return false;
    // z = a u + b v + c over the triangle; in pixels (x = u W, y = (1 - v) H,
    // rows top-down) its gradient is (a / W, -b / H).
    const double a = (e1.z * d2.y - e2.z * d1.y) / det, b = (d1.x * e2.z - d2.x * e1.z) / det;
    const double gx = a / texture.width_px, gy = -b / texture.height_px;
    return gy < 0 && std::abs(gx) <= std::tan(10.0 * M_PI / 180.0) * -gy;
}

synth::Image8 drawStylisedFacade(const FacadeSummary& summary, int width, int height, int channels) {
    synth::Image8 image;
    image.width = width, image.height = height, image.channels = channels;
    image.pixels.resize(static_cast<size_t>(width) * height * channels);
    auto fill = [&](int x0, int y0, int x1, int y1, const std::array<uint8_t, 3>& rgb, uint8_t alpha) {
        x0 = std::max(x0, 0), y0 = std::max(y0, 0), x1 = std::min(x1, width), y1 = std::min(y1, height);
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
                uint8_t* p = image.pixels.data() + (static_cast<size_t>(y) * width + x) * channels;
                p[0] = rgb[0], p[1] = rgb[1], p[2] = rgb[2];
                if (channels == 4) p[3] = alpha;
            }
    };
    fill(0, 0, width, height, summary.facade_rgb, summary.facade_alpha);
    for (int y : summary.rows.start)
        for (int x : summary.columns.start)
            fill(x, y, x + summary.columns.length, y + summary.rows.length, summary.window_rgb, summary.window_alpha);
    return image;
}

}  // namespace cityatlas
