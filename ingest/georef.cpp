// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/georef.h"

#include <cmath>
#include <limits>
#include <mutex>
#include <optional>
#include <vector>

#include <GeographicLib/Geocentric.hpp>
#include <GeographicLib/LocalCartesian.hpp>
#include <GeographicLib/Math.hpp>
#include <proj.h>
#include <proj_experimental.h>  // proj_crs_promote_to_3D

#include <fmt/format.h>

namespace cityatlas {
namespace {

// Central-difference step for the tangent-linear map, metres. Truncation error
// ~ step^2 / (6 R^2) ~ 4e-13, rounding ~ 1e-9 m / (2 step) ~ 5e-11: both far
// below anything that matters.
constexpr double kJacobianStep_m = 10.0;

struct PjDeleter {
    void operator()(PJ* p) const { proj_destroy(p); }
};
using PjPtr = std::unique_ptr<PJ, PjDeleter>;

// One PROJ context with one operation: never used by two threads at once.
struct Worker {
    PJ_CONTEXT* ctx = nullptr;
    PJ* op = nullptr;
    Worker() = default;
    Worker(const Worker&) = delete;
    Worker& operator=(const Worker&) = delete;
    ~Worker() {
        proj_destroy(op);  // before its context
        proj_context_destroy(ctx);
    }
};

std::string projError(PJ_CONTEXT* ctx) {
    const int e = proj_context_errno(ctx);
    const char* s = e ? proj_context_errno_string(ctx, e) : nullptr;
    return s ? s : "unknown PROJ error";
}

// Metres per unit of an axis of a coordinate system.
double axisUnit_m(PJ_CONTEXT* ctx, const PJ* cs, int index) {
    double factor = 1;
    if (!proj_cs_get_axis_info(ctx, cs, index, nullptr, nullptr, nullptr, &factor, nullptr, nullptr, nullptr) ||
        !(factor > 0))
        return 1;
    return factor;
}

// The source CRS as PROJ will be given it: 2D CRSs promoted to 3D (ellipsoidal
// height), compound and 3D ones as they are. *height_unit_m: metres per unit of
// its height axis (1 when it has none).
Status sourceCrs(PJ_CONTEXT* ctx, const std::string& definition, PjPtr* out, double* height_unit_m) {
    PjPtr crs(proj_create(ctx, definition.c_str()));
    if (!crs) return Status::Unsupported(fmt::format("PROJ does not know {}: {}", definition, projError(ctx)));
    *height_unit_m = 1;
    if (proj_get_type(crs.get()) == PJ_TYPE_COMPOUND_CRS) {
        PjPtr vertical(proj_crs_get_sub_crs(ctx, crs.get(), 1));
        PjPtr cs(vertical ? proj_crs_get_coordinate_system(ctx, vertical.get()) : nullptr);
        if (cs) *height_unit_m = axisUnit_m(ctx, cs.get(), 0);
        *out = std::move(crs);
        return Status::Ok();
    }
    PjPtr cs(proj_crs_get_coordinate_system(ctx, crs.get()));
    if (!cs) return Status::Unsupported(fmt::format("PROJ gives no coordinate system for {}", definition));
    if (proj_cs_get_axis_count(ctx, cs.get()) == 2) {
        // So that a datum shift with a 3D Helmert moves points as 3D points.
        PjPtr promoted(proj_crs_promote_to_3D(ctx, nullptr, crs.get()));
        if (promoted) {
            crs = std::move(promoted);
            cs.reset(proj_crs_get_coordinate_system(ctx, crs.get()));
        }
    }
    if (cs && proj_cs_get_axis_count(ctx, cs.get()) == 3) *height_unit_m = axisUnit_m(ctx, cs.get(), 2);
    *out = std::move(crs);
    return Status::Ok();
}

// A context with the operation source CRS -> `target`, axes in x east-ish,
// y north-ish order (lon, lat for geographic CRSs) on both sides.
Status makeWorker(const std::string& definition, const char* target, std::unique_ptr<Worker>* out,
                  double* height_unit_m) {
    auto w = std::make_unique<Worker>();
    w->ctx = proj_context_create();
    if (!w->ctx) return Status::Io("cannot create a PROJ context");
    proj_log_level(w->ctx, PJ_LOG_NONE);         // errors come back as Status
    proj_context_set_enable_network(w->ctx, 0);  // offline and reproducible: only installed grids
    PjPtr src;
    if (Status s = sourceCrs(w->ctx, definition, &src, height_unit_m); !s.ok()) return s;
    PjPtr dst(proj_create(w->ctx, target));
    if (!dst) return Status::Unsupported(fmt::format("PROJ does not know {}: {}", target, projError(w->ctx)));
    PjPtr op(proj_create_crs_to_crs_from_pj(w->ctx, src.get(), dst.get(), nullptr, nullptr));
    if (!op)
        return Status::Unsupported(
            fmt::format("PROJ has no transformation from {} to {}: {}", definition, target, projError(w->ctx)));
    w->op = proj_normalize_for_visualization(w->ctx, op.get());
    if (!w->op)
        return Status::Unsupported(fmt::format("PROJ cannot normalise the axis order of {} -> {}", definition, target));
    *out = std::move(w);
    return Status::Ok();
}

bool finite(const Vec3d& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace

struct LocalToEcef::Impl {
    SourceCrs crs;
    Vec3d origin;                                          // source CRS units (lon/lat degrees for geographic)
    std::optional<GeographicLib::LocalCartesian> tangent;  // ENU frames: the same one LocalFrame uses
    double height_unit_m = 1;                              // metres per unit of PROJ's source height axis
    EarthFrame earth;
    std::array<double, 16> tangent_linear{};

    mutable std::mutex mutex;
    mutable std::vector<std::unique_ptr<Worker>> pool;  // idle workers (source -> EPSG:4978)

    std::unique_ptr<Worker> borrow() const {
        {
            std::lock_guard lock(mutex);
            if (!pool.empty()) {
                std::unique_ptr<Worker> w = std::move(pool.back());
                pool.pop_back();
                return w;
            }
        }
        std::unique_ptr<Worker> w;
        double unit = 1;
        if (!makeWorker(crs.definition, "EPSG:4978", &w, &unit).ok()) return nullptr;  // create() made one already
        return w;
    }
    void giveBack(std::unique_ptr<Worker> w) const {
        std::lock_guard lock(mutex);
        pool.push_back(std::move(w));
    }

    // The point in the source CRS as the PROJ operation takes it.
    bool sourceOf(const Vec3d& local, PJ_COORD* c) const {
        double h_m = 0;
        if (tangent) {
            double lat = 0, lon = 0;
            tangent->Reverse(local.x, local.y, local.z, lat, lon, h_m);
            *c = proj_coord(lon, lat, h_m / height_unit_m, 0);
        } else {
            // The inverse of LocalFrame::frameToLocal: x, y scaled by the linear
            // unit, heights unscaled (LocalFrame takes the file's z as metres).
            const double u = crs.linear_unit_m;
            h_m = origin.z + local.z;
            *c = proj_coord(origin.x + local.x / u, origin.y + local.y / u, h_m / height_unit_m, 0);
        }
        return std::isfinite(c->v[0]) && std::isfinite(c->v[1]) && std::isfinite(c->v[2]);
    }

    bool transform(const Worker& w, const Vec3d& local, Vec3d* ecef) const {
        PJ_COORD c;
        if (!sourceOf(local, &c)) {
            *ecef = {kNaN, kNaN, kNaN};
            return false;
        }
        c = proj_trans(w.op, PJ_FWD, c);
        *ecef = {c.xyz.x, c.xyz.y, c.xyz.z};
        return finite(*ecef);
    }

    Vec3d ecefToEnu(const Vec3d& ecef) const {
        const auto& m = earth.enu_to_ecef;
        const Vec3d d = ecef - earth.origin_ecef;
        // R^T d: the rotation's columns are the east, north, up unit vectors.
        return {m[0] * d.x + m[1] * d.y + m[2] * d.z, m[4] * d.x + m[5] * d.y + m[6] * d.z,
                m[8] * d.x + m[9] * d.y + m[10] * d.z};
    }
};

LocalToEcef::LocalToEcef() : impl_(std::make_unique<Impl>()) {}
LocalToEcef::~LocalToEcef() = default;

const EarthFrame& LocalToEcef::earth() const { return impl_->earth; }

Status LocalToEcef::create(const LocalFrame& frame, std::unique_ptr<LocalToEcef>* out) {
    const SourceCrs& crs = frame.crs();
    if (crs.kind == SourceCrs::Kind::LocalEngineering)
        return Status::Unsupported(fmt::format("{} has no link to the Earth: the scene cannot be georeferenced", crs.name));
    std::unique_ptr<LocalToEcef> self(new LocalToEcef);
    Impl& m = *self->impl_;
    m.crs = crs;
    m.origin = frame.originSource();
    m.earth.grid = crs.kind == SourceCrs::Kind::Projected;
    if (crs.kind == SourceCrs::Kind::Geographic) {
        const double flattening = crs.inverse_flattening > 0 ? 1.0 / crs.inverse_flattening : 0.0;
        m.tangent.emplace(m.origin.y, m.origin.x, m.origin.z, GeographicLib::Geocentric(crs.semi_major_m, flattening));
    }

    // The origin on WGS 84 (lat, lon, h), through PROJ to EPSG:4979.
    std::unique_ptr<Worker> geographic;
    double unit = 1;
    if (Status s = makeWorker(crs.definition, "EPSG:4979", &geographic, &unit); !s.ok()) return s;
    std::unique_ptr<Worker> ecef;
    if (Status s = makeWorker(crs.definition, "EPSG:4978", &ecef, &m.height_unit_m); !s.ok()) return s;
    PJ_COORD c;
    m.sourceOf({0, 0, 0}, &c);
    const PJ_COORD llh = proj_trans(geographic->op, PJ_FWD, c);
    if (!std::isfinite(llh.lpz.lam) || !std::isfinite(llh.lpz.phi) || !std::isfinite(llh.lpz.z))
        return Status::Unsupported(fmt::format("PROJ cannot transform the scene origin ({}, {}, {}) from {} to WGS 84: {}",
                                        m.origin.x, m.origin.y, m.origin.z, crs.name, projError(geographic->ctx)));
    m.earth.origin_lon_deg = llh.lpz.lam;
    m.earth.origin_lat_deg = llh.lpz.phi;
    m.earth.origin_h_m = llh.lpz.z;

    if (!m.transform(*ecef, {0, 0, 0}, &m.earth.origin_ecef))
        return Status::Unsupported(fmt::format("PROJ cannot transform the scene origin ({}, {}, {}) from {} to ECEF: {}",
                                        m.origin.x, m.origin.y, m.origin.z, crs.name, projError(ecef->ctx)));
    if (PjPtr used{proj_trans_get_last_used_operation(ecef->op)}) {
        const char* name = proj_get_name(used.get());
        m.earth.operation = name ? name : "";
    }

    // ENU at the origin: columns east, north, up (WGS 84 normal), origin.
    double sphi, cphi, slam, clam;
    GeographicLib::Math::sincosd(m.earth.origin_lat_deg, sphi, cphi);
    GeographicLib::Math::sincosd(m.earth.origin_lon_deg, slam, clam);
    const Vec3d& o = m.earth.origin_ecef;
    m.earth.enu_to_ecef = {-slam,        clam,         0,    0,  //
                           -sphi * clam, -sphi * slam, cphi, 0,  //
                           cphi * clam,  cphi * slam,  sphi, 0,  //
                           o.x,          o.y,          o.z,  1};

    // Tangent-linear map: central differences along each local axis.
    m.tangent_linear = m.earth.enu_to_ecef;
    for (int axis = 0; axis < 3; ++axis) {
        Vec3d step;
        (axis == 0 ? step.x : axis == 1 ? step.y : step.z) = kJacobianStep_m;
        Vec3d plus, minus;
        if (!m.transform(*ecef, step, &plus) || !m.transform(*ecef, -1.0 * step, &minus))
            return Status::Unsupported(fmt::format("PROJ cannot transform points {} m from the scene origin in {}",
                                            kJacobianStep_m, crs.name));
        const Vec3d column = (1.0 / (2 * kJacobianStep_m)) * (plus - minus);
        m.tangent_linear[4 * axis + 0] = column.x;
        m.tangent_linear[4 * axis + 1] = column.y;
        m.tangent_linear[4 * axis + 2] = column.z;
    }
    m.pool.push_back(std::move(ecef));
    *out = std::move(self);
    return Status::Ok();
}

bool LocalToEcef::toEcef(const Vec3d& local, Vec3d* ecef) const {
    std::unique_ptr<Worker> w = impl_->borrow();
    if (!w) {
        *ecef = {kNaN, kNaN, kNaN};
        return false;
    }
    const bool ok = impl_->transform(*w, local, ecef);
    impl_->giveBack(std::move(w));
    return ok;
}

bool LocalToEcef::toEcef(std::span<const Vec3d> local, std::span<Vec3d> ecef) const {
    if (local.size() != ecef.size()) return false;
    std::unique_ptr<Worker> w = impl_->borrow();
    if (!w) {
        for (Vec3d& e : ecef) e = {kNaN, kNaN, kNaN};
        return false;
    }
    bool ok = true;
    for (size_t i = 0; i < local.size(); ++i) ok &= impl_->transform(*w, local[i], &ecef[i]);
    impl_->giveBack(std::move(w));
    return ok;
}

bool LocalToEcef::toEnu(const Vec3d& local, Vec3d* enu) const {
    Vec3d ecef;
    if (!toEcef(local, &ecef)) {
        *enu = {kNaN, kNaN, kNaN};
        return false;
    }
    *enu = impl_->ecefToEnu(ecef);
    return true;
}

bool LocalToEcef::planarError(const Vec3d& local, double* horizontal_m, double* vertical_m) const {
    Vec3d enu;
    if (!toEnu(local, &enu)) {
        *horizontal_m = *vertical_m = kNaN;
        return false;
    }
    const Vec3d d = enu - local;
    *horizontal_m = std::hypot(d.x, d.y);
    *vertical_m = std::abs(d.z);
    return true;
}

Status computeEarthFrame(const LocalFrame& frame, EarthFrame* out) {
    std::unique_ptr<LocalToEcef> map;
    if (Status s = LocalToEcef::create(frame, &map); !s.ok()) return s;
    *out = map->earth();
    return Status::Ok();
}

std::array<double, 16> tangentLinearLocalToEcef(const LocalToEcef& map) { return map.impl_->tangent_linear; }

std::array<double, 16> localToEcefMatrix(const LocalToEcef& map) {
    return map.grid() ? tangentLinearLocalToEcef(map) : map.earth().enu_to_ecef;
}

Vec3d transformPoint(const std::array<double, 16>& m, const Vec3d& p) {
    return {m[0] * p.x + m[4] * p.y + m[8] * p.z + m[12], m[1] * p.x + m[5] * p.y + m[9] * p.z + m[13],
            m[2] * p.x + m[6] * p.y + m[10] * p.z + m[14]};
}

Status summarizeGeoreference(const LocalFrame& frame, const Box3d& bounds_local, GeorefSummary* out) {
    std::unique_ptr<LocalToEcef> map;
    if (Status s = LocalToEcef::create(frame, &map); !s.ok()) return s;
    out->earth = map->earth();
    out->local_to_ecef = localToEcefMatrix(*map);
    out->planar_error_horizontal_m = out->planar_error_vertical_m = out->extent_m = 0;
    if (bounds_local.empty()) return Status::Ok();
    for (int c = 0; c < 8; ++c) {
        const Vec3d p{(c & 1) ? bounds_local.max.x : bounds_local.min.x, (c & 2) ? bounds_local.max.y : bounds_local.min.y,
                      (c & 4) ? bounds_local.max.z : bounds_local.min.z};
        // The matrix against the real transformation, at this corner.
        Vec3d exact;
        if (!map->toEcef(p, &exact)) continue;
        const Vec3d d = transformPoint(out->local_to_ecef, p) - exact;
        const std::array<double, 16>& m = out->earth.enu_to_ecef;
        const Vec3d up{m[8], m[9], m[10]};
        const double vertical = std::abs(dot(d, up));
        out->planar_error_vertical_m = std::max(out->planar_error_vertical_m, vertical);
        out->planar_error_horizontal_m =
            std::max(out->planar_error_horizontal_m, std::sqrt(std::max(0.0, dot(d, d) - vertical * vertical)));
        out->extent_m = std::max(out->extent_m, std::hypot(p.x, p.y));
    }
    return Status::Ok();
}

}  // namespace cityatlas
