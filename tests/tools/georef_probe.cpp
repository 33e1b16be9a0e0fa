// SPDX-License-Identifier: GPL-3.0-or-later
// georef_probe SRS X Y Z [ORIGIN_X ORIGIN_Y ORIGIN_Z]
//
// Prints "X Y Z" (ECEF, EPSG:4978, metres, %.4f) of the source point (X, Y, Z)
// as cityatlas computes it: a LocalFrame from parseSrsName(SRS) with the origin
// (default: the point itself), the point mapped into that frame with the
// frame's Mapper, then LocalToEcef::toEcef. Coordinates are in x east-ish,
// y north-ish order, as LocalFrame takes them: easting northing height for a
// projected CRS, lon lat h (degrees, metres) for a geographic one, whatever the
// EPSG axis order. tests/cli/georef_cs2cs.sh compares the output with cs2cs.
#include <charconv>
#include <cstdio>
#include <cstring>
#include <string>

#include "ingest/georef.h"
#include "ingest/local_frame.h"

namespace {

bool parse(const char* s, double* v) {
    const char* end = s + std::strlen(s);
    auto [p, ec] = std::from_chars(s, end, *v);
    return ec == std::errc() && p == end;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace cityatlas;
    if (argc != 5 && argc != 8) {
        std::fprintf(stderr, "usage: georef_probe SRS X Y Z [ORIGIN_X ORIGIN_Y ORIGIN_Z]\n");
        return 2;
    }
    double v[6];
    for (int i = 0; i < argc - 2; ++i)
        if (!parse(argv[i + 2], &v[i])) {
            std::fprintf(stderr, "georef_probe: not a number: %s\n", argv[i + 2]);
            return 2;
        }
    const Vec3d point{v[0], v[1], v[2]};
    const Vec3d origin = argc == 8 ? Vec3d{v[3], v[4], v[5]} : point;

    SourceCrs crs;
    std::unique_ptr<LocalFrame> frame;
    std::unique_ptr<LocalFrame::Mapper> mapper;
    std::unique_ptr<LocalToEcef> to_ecef;
    Status s = parseSrsName(argv[1], &crs);
    if (s.ok()) s = LocalFrame::create(crs, origin, &frame);
    if (s.ok()) s = frame->mapperFor(crs, &mapper);
    if (s.ok()) s = LocalToEcef::create(*frame, &to_ecef);
    if (!s.ok()) {
        std::fprintf(stderr, "georef_probe: %s\n", s.error.c_str());
        return 1;
    }
    Vec3d local, ecef;
    if (!mapper->toLocal(point, &local) || !to_ecef->toEcef(local, &ecef)) {
        std::fprintf(stderr, "georef_probe: the point cannot be transformed\n");
        return 1;
    }
    std::printf("%.4f %.4f %.4f\n", ecef.x, ecef.y, ecef.z);
    return 0;
}
