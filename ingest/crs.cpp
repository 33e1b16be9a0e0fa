// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/crs.h"

#include <cpl_error.h>
#include <ogr_spatialref.h>

#include <fmt/format.h>

namespace cityatlas {

Status lookupCrs(int epsg, CrsInfo* info) {
    OGRSpatialReference srs;
    // Silence GDAL's own stderr message; we report the failure ourselves.
    CPLPushErrorHandler(CPLQuietErrorHandler);
    const OGRErr err = srs.importFromEPSG(epsg);
    CPLPopErrorHandler();
    if (err != OGRERR_NONE) return Status::Unsupported(fmt::format("EPSG:{} is not a CRS known to PROJ's database", epsg));
    info->epsg = epsg;
    info->name = srs.GetName() ? srs.GetName() : "";
    info->projected = srs.IsProjected();
    info->linear_unit_m = srs.IsProjected() ? srs.GetLinearUnits() : 0.0;
    return Status::Ok();
}

Status requireProjectedMetricCrs(int epsg, CrsInfo* info) {
    Status s = lookupCrs(epsg, info);
    if (!s.ok()) return s;
    if (!info->projected)
        return Status::Unsupported(fmt::format("EPSG:{} ({}) is not a projected CRS; a projected CRS in metres is needed",
                                        epsg, info->name));
    if (info->linear_unit_m != 1.0)
        return Status::Unsupported(fmt::format("EPSG:{} ({}) has axes in units of {} m, not metres", epsg, info->name,
                                        info->linear_unit_m));
    return Status::Ok();
}

std::string epsgUrn(int epsg) { return fmt::format("urn:ogc:def:crs:EPSG::{}", epsg); }

}  // namespace cityatlas
