// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/local_frame.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <vector>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>
#include <cpl_error.h>
#include <ogr_spatialref.h>

#include <fmt/format.h>

namespace cityatlas {
namespace {

// AdV (German surveying authorities) URNs name CRSs without EPSG codes.
// Horizontal part before the first '*', vertical part after it.
const std::map<std::string, int> kAdvHorizontal = {
    {"ETRS89_UTM31", 25831}, {"ETRS89_UTM32", 25832}, {"ETRS89_UTM33", 25833},
    {"DE_DHDN_3GK2", 31466}, {"DE_DHDN_3GK3", 31467}, {"DE_DHDN_3GK4", 31468}, {"DE_DHDN_3GK5", 31469},
};
const std::map<std::string, int> kAdvVertical = {{"DE_DHHN2016_NH", 7837}, {"DE_DHHN92_NH", 5783}};

// The trailing run of digits of `s`, or -1.
int trailingCode(std::string_view s) {
    size_t end = s.size();
    while (end > 0 && !std::isdigit(static_cast<unsigned char>(s[end - 1]))) --end;  // tolerate "25832/" etc.
    size_t begin = end;
    while (begin > 0 && std::isdigit(static_cast<unsigned char>(s[begin - 1]))) --begin;
    if (begin == end || end - begin > 9) return -1;
    return std::stoi(std::string(s.substr(begin, end - begin)));
}

// EPSG codes named by an srsName, horizontal first; empty if none recognised.
std::vector<int> epsgCodes(const std::string& srs) {
    std::vector<int> codes;
    if (srs.rfind("urn:adv:crs:", 0) == 0) {
        std::string rest = srs.substr(12);
        std::vector<std::string> parts;
        size_t pos = 0;
        while (true) {
            size_t star = rest.find('*', pos);
            parts.push_back(rest.substr(pos, star == std::string::npos ? std::string::npos : star - pos));
            if (star == std::string::npos) break;
            pos = star + 1;
        }
        if (auto h = kAdvHorizontal.find(parts[0]); h != kAdvHorizontal.end()) {
            codes.push_back(h->second);
            if (parts.size() > 1)
                if (auto v = kAdvVertical.find(parts[1]); v != kAdvVertical.end()) codes.push_back(v->second);
        }
        return codes;
    }
    // Compound URNs list their parts after commas; OGC compound URLs use "&";
    // PROJ's own short form is "EPSG:25832+7837".
    size_t start = 0;
    while (start <= srs.size()) {
        size_t end = srs.find_first_of(",&+", start);
        std::string part = srs.substr(start, end == std::string::npos ? std::string::npos : end - start);
        const bool plus_part = start > 0 && srs[start - 1] == '+' && !part.empty() &&
                               std::all_of(part.begin(), part.end(), [](unsigned char c) { return std::isdigit(c); });
        if (plus_part || part.find("EPSG") != std::string::npos || part.find("epsg") != std::string::npos) {
            int c = trailingCode(part);
            if (c > 0) codes.push_back(c);
        }
        if (end == std::string::npos) break;
        start = end + 1;
    }
    return codes;
}

}  // namespace

Status parseSrsName(const std::string& srs_name, SourceCrs* crs) {
    crs->declared = srs_name;
    if (!srs_name.empty() && srs_name[0] == '#') {
        crs->kind = SourceCrs::Kind::LocalEngineering;
        crs->definition.clear();
        crs->name = "local engineering CRS " + srs_name;
        return Status::Ok();
    }
    const std::vector<int> codes = epsgCodes(srs_name);
    if (codes.empty()) return Status::Unsupported(fmt::format("srsName \"{}\" names no CRS that PROJ knows", srs_name));
    std::string definition = fmt::format("EPSG:{}", codes[0]);
    if (codes.size() > 1) definition += fmt::format("+{}", codes[1]);
    crs->vertical_ignored.clear();
    Status s = sourceCrsFromDefinition(definition, crs);
    if (!s.ok() && codes.size() > 1) {  // an unusable vertical part: keep the horizontal one
        crs->vertical_ignored = fmt::format("EPSG:{}", codes[1]);
        s = sourceCrsFromDefinition(fmt::format("EPSG:{}", codes[0]), crs);
    }
    if (!s.ok()) return Status::Unsupported(fmt::format("srsName \"{}\": {}", srs_name, s.error));
    return Status::Ok();
}

Status sourceCrsFromDefinition(const std::string& definition, SourceCrs* crs) {
    OGRSpatialReference srs;
    CPLPushErrorHandler(CPLQuietErrorHandler);
    // File and network access forbidden: only a code or WKT is accepted.
    const OGRErr err = srs.SetFromUserInput(definition.c_str(), OGRSpatialReference::SET_FROM_USER_INPUT_LIMITATIONS);
    CPLPopErrorHandler();
    const std::string shown = definition.size() <= 64 ? definition : definition.substr(0, 61) + "...";
    if (err != OGRERR_NONE) return Status::Unsupported(fmt::format("{} is not a CRS known to PROJ's database", shown));
    crs->definition = definition;
    crs->name = srs.GetName() ? srs.GetName() : shown;
    if (srs.IsProjected()) {
        crs->kind = SourceCrs::Kind::Projected;
        crs->linear_unit_m = srs.GetLinearUnits();
    } else if (srs.IsGeographic()) {
        crs->kind = SourceCrs::Kind::Geographic;
        crs->semi_major_m = srs.GetSemiMajor();
        crs->inverse_flattening = srs.GetInvFlattening();
    } else {
        return Status::Unsupported(fmt::format("{} ({}) is neither projected nor geographic", shown, crs->name));
    }
    return Status::Ok();
}

struct LocalFrame::Tangent {
    GeographicLib::LocalCartesian enu;
};

struct LocalFrame::Mapper::Transform {
    std::unique_ptr<OGRCoordinateTransformation> ct;
    double source_unit_m = 1;
};

LocalFrame::~LocalFrame() = default;
LocalFrame::Mapper::~Mapper() = default;

Status LocalFrame::create(const SourceCrs& crs, const Vec3d& origin_source, std::unique_ptr<LocalFrame>* frame) {
    if (!std::isfinite(origin_source.x) || !std::isfinite(origin_source.y) || !std::isfinite(origin_source.z))
        return Status::Invalid("the scene origin is not finite");
    std::unique_ptr<LocalFrame> f(new LocalFrame);
    f->crs_ = crs;
    f->origin_ = origin_source;
    if (crs.kind == SourceCrs::Kind::Geographic) {
        if (std::abs(origin_source.y) > 90) return Status::Invalid("the scene origin's latitude is beyond +-90 degrees");
        const double flattening = crs.inverse_flattening > 0 ? 1.0 / crs.inverse_flattening : 0.0;
        f->tangent_ = std::make_unique<Tangent>(Tangent{GeographicLib::LocalCartesian(
            origin_source.y, origin_source.x, origin_source.z, GeographicLib::Geocentric(crs.semi_major_m, flattening))});
    }
    *frame = std::move(f);
    return Status::Ok();
}

Vec3d LocalFrame::frameToLocal(const Vec3d& p) const {
    switch (crs_.kind) {
        case SourceCrs::Kind::Projected: {
            const double u = crs_.linear_unit_m;
            return {(p.x - origin_.x) * u, (p.y - origin_.y) * u, p.z - origin_.z};
        }
        case SourceCrs::Kind::Geographic: {
            Vec3d out;
            tangent_->enu.Forward(p.y, p.x, p.z, out.x, out.y, out.z);
            return out;
        }
        case SourceCrs::Kind::LocalEngineering: return p - origin_;
    }
    return p;
}

Status LocalFrame::mapperFor(const SourceCrs& source, std::unique_ptr<Mapper>* mapper) const {
    auto m = std::make_unique<Mapper>();
    m->frame_ = this;
    const bool same = source.kind == crs_.kind && source.definition == crs_.definition;
    if (!same) {
        if (source.kind == SourceCrs::Kind::LocalEngineering || crs_.kind == SourceCrs::Kind::LocalEngineering)
            return Status::Unsupported(fmt::format("cannot combine {} with {}: a local engineering CRS has no link to Earth",
                                            source.name, crs_.name));
        OGRSpatialReference from, to;
        from.SetFromUserInput(source.definition.c_str(), OGRSpatialReference::SET_FROM_USER_INPUT_LIMITATIONS);
        to.SetFromUserInput(crs_.definition.c_str(), OGRSpatialReference::SET_FROM_USER_INPUT_LIMITATIONS);
        from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
        to.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
        CPLPushErrorHandler(CPLQuietErrorHandler);
        std::unique_ptr<OGRCoordinateTransformation> ct(OGRCreateCoordinateTransformation(&from, &to));
        CPLPopErrorHandler();
        if (!ct) return Status::Unsupported(fmt::format("PROJ has no transformation from {} to {}", source.name, crs_.name));
        m->transform_ = std::make_unique<Mapper::Transform>(Mapper::Transform{std::move(ct), 1.0});
    }
    *mapper = std::move(m);
    return Status::Ok();
}

bool LocalFrame::Mapper::toFrameCrs(const Vec3d& source, Vec3d* frame_crs) const {
    *frame_crs = source;
    if (!transform_) return true;
    return transform_->ct->Transform(1, &frame_crs->x, &frame_crs->y, &frame_crs->z) != 0 &&
           std::isfinite(frame_crs->x) && std::isfinite(frame_crs->y);
}

bool LocalFrame::Mapper::toLocal(const Vec3d& source, Vec3d* local) const {
    Vec3d p;
    if (!toFrameCrs(source, &p)) return false;
    *local = frame_->frameToLocal(p);
    return std::isfinite(local->x) && std::isfinite(local->y) && std::isfinite(local->z);
}

}  // namespace cityatlas
