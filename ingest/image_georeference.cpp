// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/image_georeference.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>

#include <cmath>
#include <mutex>

namespace cityatlas {

std::optional<std::array<double, 6>> readImageGeoreference(const std::filesystem::path& image, bool prefer_world_file) {
    static std::once_flag registered;
    std::call_once(registered, [] { GDALAllRegister(); });
    CPLPushErrorHandler(CPLQuietErrorHandler);
    // GDAL's own order puts the image's tags first; CityGML's default is the
    // world file first. Drivers without the option ignore it.
    const char* sources = prefer_world_file ? "GEOREF_SOURCES=WORLDFILE,INTERNAL,PAM,TABFILE"
                                            : "GEOREF_SOURCES=INTERNAL,PAM,TABFILE,WORLDFILE";
    const char* const options[] = {sources, nullptr};
    GDALDataset* ds = GDALDataset::FromHandle(
        GDALOpenEx(image.string().c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, options, nullptr));
    std::optional<std::array<double, 6>> out;
    double gt[6];
    if (ds && ds->GetGeoTransform(gt) == CE_None) {
        // GDAL's transform is to pixel corners: the centre of pixel (0, 0) is half a pixel in.
        const std::array<double, 6> a = {gt[1], gt[2], gt[0] + 0.5 * (gt[1] + gt[2]),
                                         gt[4], gt[5], gt[3] + 0.5 * (gt[4] + gt[5])};
        bool finite = true;
        for (double v : a) finite &= std::isfinite(v);
        if (finite && a[0] * a[4] - a[1] * a[3] != 0) out = a;
    }
    if (ds) GDALClose(ds);
    CPLErrorReset();
    CPLPopErrorHandler();
    return out;
}

}  // namespace cityatlas
