// SPDX-License-Identifier: GPL-3.0-or-later
// image_compare TEST.png REFERENCE.png R,G,B
// Compares a rendered frame with a reference frame of the same view, read
// with OpenImageIO: prints one JSON line with the PSNR over RGB (dB; 99 when
// identical) and the number of "holes": pixels that show the clear colour
// R,G,B (sRGB bytes, +-2) in TEST where REFERENCE shows something else (a
// facade drawn in the reference but missing in the test). `holes` counts
// every such pixel; `interior_holes` only those whose 3x3 neighbourhood is
// covered in the reference, i.e. not on a silhouette, where two meshes of the
// same surface (a node's merged geometry and its leaves', quantized about
// different centres) may rasterize one pixel apart. For two renderers of the
// same view (a browser client against `cityatlas render`): the silhouettes'
// agreement, intersection over union of the covered (non-clear) pixels, and
// the PSNR over the pixels both cover. Exit 2 on bad input.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

namespace {

bool readRgb(const char* path, int* w, int* h, std::vector<unsigned char>* rgb) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        std::fprintf(stderr, "image_compare: %s: %s\n", path, OIIO::geterror().c_str());
        return false;
    }
    const OIIO::ImageSpec& spec = in->spec();
    *w = spec.width;
    *h = spec.height;
    std::vector<unsigned char> all(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, all.data())) {
        std::fprintf(stderr, "image_compare: %s: %s\n", path, in->geterror().c_str());
        return false;
    }
    rgb->resize(static_cast<size_t>(*w) * *h * 3);
    for (size_t i = 0, n = static_cast<size_t>(*w) * *h; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            (*rgb)[i * 3 + static_cast<size_t>(c)] = all[i * static_cast<size_t>(spec.nchannels) + static_cast<size_t>(std::min(c, spec.nchannels - 1))];
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    int clear[3];
    if (argc != 4 || std::sscanf(argv[3], "%d,%d,%d", &clear[0], &clear[1], &clear[2]) != 3) {
        std::fprintf(stderr, "usage: image_compare TEST.png REFERENCE.png R,G,B\n");
        return 2;
    }
    int w1 = 0, h1 = 0, w2 = 0, h2 = 0;
    std::vector<unsigned char> a, b;
    if (!readRgb(argv[1], &w1, &h1, &a) || !readRgb(argv[2], &w2, &h2, &b)) return 2;
    if (w1 != w2 || h1 != h2) {
        std::fprintf(stderr, "image_compare: sizes differ: %dx%d and %dx%d\n", w1, h1, w2, h2);
        return 2;
    }
    double se = 0, se_both = 0;
    long holes = 0, interior_holes = 0, reference_covered = 0, covered_both = 0, covered_either = 0;
    auto isClear = [&](const unsigned char* p) {
        return std::abs(p[0] - clear[0]) <= 2 && std::abs(p[1] - clear[1]) <= 2 && std::abs(p[2] - clear[2]) <= 2;
    };
    for (size_t i = 0, n = static_cast<size_t>(w1) * h1; i < n; ++i) {
        for (int c = 0; c < 3; ++c) {
            const double d = static_cast<double>(a[i * 3 + static_cast<size_t>(c)]) - b[i * 3 + static_cast<size_t>(c)];
            se += d * d;
        }
        const bool ref_clear = isClear(&b[i * 3]);
        reference_covered += ref_clear ? 0 : 1;
        const bool test_clear = isClear(&a[i * 3]);
        covered_either += ref_clear && test_clear ? 0 : 1;
        if (!ref_clear && !test_clear) {
            ++covered_both;
            for (int c = 0; c < 3; ++c) {
                const double d = static_cast<double>(a[i * 3 + static_cast<size_t>(c)]) - b[i * 3 + static_cast<size_t>(c)];
                se_both += d * d;
            }
        }
        if (isClear(&a[i * 3]) && !ref_clear) {
            ++holes;
            const long x = static_cast<long>(i % static_cast<size_t>(w1)), y = static_cast<long>(i / static_cast<size_t>(w1));
            bool interior = true;
            for (long dy = -1; dy <= 1 && interior; ++dy)
                for (long dx = -1; dx <= 1 && interior; ++dx) {
                    const long xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= w1 || yy >= h1) continue;
                    interior = !isClear(&b[(static_cast<size_t>(yy) * static_cast<size_t>(w1) + static_cast<size_t>(xx)) * 3]);
                }
            interior_holes += interior ? 1 : 0;
        }
    }
    const double mse = se / (3.0 * w1 * h1);
    const double psnr = mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : 99.0;
    const double mse_both = covered_both ? se_both / (3.0 * static_cast<double>(covered_both)) : 0;
    const double psnr_both = mse_both > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse_both) : 99.0;
    const double iou = covered_either ? static_cast<double>(covered_both) / static_cast<double>(covered_either) : 1.0;
    std::printf("{\"psnr_db\": %.3f, \"holes\": %ld, \"interior_holes\": %ld, \"reference_covered\": %ld, \"pixels\": %ld, "
                "\"silhouette_iou\": %.4f, \"covered_both\": %ld, \"psnr_covered_db\": %.3f}\n",
                psnr, holes, interior_holes, reference_covered, static_cast<long>(w1) * h1, iou, covered_both, psnr_both);
    return 0;
}
