// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// Coordinate reference systems, by EPSG code, through GDAL's
/// OGRSpatialReference (which asks PROJ's database; no network).

#include <string>

#include "core/status.h"

namespace cityatlas {

struct CrsInfo {
    int epsg = 0;
    std::string name;        ///< e.g. "ETRS89 / UTM zone 32N"
    bool projected = false;
    double linear_unit_m = 0;  ///< metres per unit of the horizontal axes
};

/// Looks up an EPSG code. Fails with a one-line message for unknown codes.
Status lookupCrs(int epsg, CrsInfo* info);

/// Fails unless `epsg` is a projected CRS with metre axes (what the synthetic
/// town generator and the local-frame arithmetic assume).
Status requireProjectedMetricCrs(int epsg, CrsInfo* info);

/// "urn:ogc:def:crs:EPSG::25832", the form CityGML files commonly carry.
std::string epsgUrn(int epsg);

}  // namespace cityatlas
