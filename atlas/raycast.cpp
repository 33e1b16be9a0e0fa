// SPDX-License-Identifier: GPL-3.0-or-later
#include "atlas/raycast.h"

#include <embree3/rtcore.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace cityatlas::atlas {
namespace {

Vec3d unit(const Vec3d& v) { return (1.0 / length(v)) * v; }

bool finite(const Vec3d& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Ties at one distance: every candidate at exactly `distance` is rejected
// (the traversal goes on through all of them) and the lowest index is kept.
struct TieContext {
    RTCIntersectContext base;  // first: Embree passes a pointer to it
    float distance = 0;
    uint32_t lowest = UINT32_MAX;
};

void lowestAtDistance(const RTCFilterFunctionNArguments* args) {
    auto* ctx = reinterpret_cast<TieContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        if (RTCRayN_tfar(args->ray, args->N, i) == ctx->distance)
            ctx->lowest = std::min(ctx->lowest, RTCHitN_primID(args->hit, args->N, i));
        args->valid[i] = 0;
    }
}

}  // namespace

struct RayCaster::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<uint32_t> original;  // Embree's primitive id -> the caller's triangle index
    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }
};

RayCaster::~RayCaster() = default;

std::unique_ptr<RayCaster> RayCaster::build(const std::vector<std::array<Vec3d, 3>>& triangles, int threads) {
    std::unique_ptr<RayCaster> rc(new RayCaster());
    rc->impl_ = std::make_unique<Impl>();
    Impl& m = *rc->impl_;
    const std::string config = threads > 0 ? "threads=" + std::to_string(threads) : std::string();
    m.device = rtcNewDevice(config.empty() ? nullptr : config.c_str());
    if (!m.device) throw std::runtime_error("embree: cannot create a device");
    m.scene = rtcNewScene(m.device);
    rtcSetSceneFlags(m.scene, static_cast<RTCSceneFlags>(RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION));
    rtcSetSceneBuildQuality(m.scene, RTC_BUILD_QUALITY_HIGH);

    Box3d box;
    for (const auto& t : triangles)
        if (finite(t[0]) && finite(t[1]) && finite(t[2]))
            for (const Vec3d& p : t) box.extend(p);
    if (!box.empty()) rc->centre_ = 0.5 * (box.min + box.max);
    const Vec3d c = rc->centre_;

    std::vector<float> vertices;
    for (uint32_t i = 0; i < triangles.size(); ++i) {
        const auto& t = triangles[i];
        if (!finite(t[0]) || !finite(t[1]) || !finite(t[2])) continue;
        std::array<Vec3d, 3> f;
        for (int k = 0; k < 3; ++k) {
            const Vec3d r = t[static_cast<size_t>(k)] - c;
            f[static_cast<size_t>(k)] = {static_cast<float>(r.x), static_cast<float>(r.y), static_cast<float>(r.z)};
        }
        // Zero area once in float: it can hit nothing, and Embree's builder would carry it for nothing.
        if (length(cross(f[1] - f[0], f[2] - f[0])) == 0) continue;
        for (const Vec3d& p : f) {
            vertices.push_back(static_cast<float>(p.x));
            vertices.push_back(static_cast<float>(p.y));
            vertices.push_back(static_cast<float>(p.z));
        }
        m.original.push_back(i);
    }
    rc->kept_ = m.original.size();
    if (!m.original.empty()) {
        RTCGeometry g = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_TRIANGLE);
        auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                              3 * sizeof(float), vertices.size() / 3));
        std::copy(vertices.begin(), vertices.end(), v);
        auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                   3 * sizeof(uint32_t), m.original.size()));
        for (uint32_t k = 0; k < 3 * m.original.size(); ++k) idx[k] = k;
        rtcCommitGeometry(g);
        rtcAttachGeometry(m.scene, g);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(m.scene);
    if (rtcGetDeviceError(m.device) != RTC_ERROR_NONE) throw std::runtime_error("embree: the scene did not build");
    return rc;
}

namespace {
RTCRay makeRay(const Vec3d& origin, const Vec3d& direction, const Vec3d& centre, double near_m, double far_m) {
    const Vec3d o = origin - centre;
    const Vec3d d = unit(direction);
    RTCRay r{};
    r.org_x = static_cast<float>(o.x);
    r.org_y = static_cast<float>(o.y);
    r.org_z = static_cast<float>(o.z);
    r.dir_x = static_cast<float>(d.x);
    r.dir_y = static_cast<float>(d.y);
    r.dir_z = static_cast<float>(d.z);
    r.tnear = static_cast<float>(std::max(0.0, near_m));
    r.tfar = std::isfinite(far_m) ? static_cast<float>(far_m) : std::numeric_limits<float>::infinity();
    r.mask = 0xFFFFFFFFu;
    r.flags = 0;
    return r;
}
}  // namespace

bool RayCaster::occluded(const Vec3d& origin, const Vec3d& direction, double near_m, double far_m) const {
    if (kept_ == 0 || !(length(direction) > 0) || !finite(origin)) return false;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRay r = makeRay(origin, direction, centre_, near_m, far_m);
    rtcOccluded1(impl_->scene, &ctx, &r);
    return r.tfar < 0;  // Embree marks an occluded ray with tfar = -inf
}

RayHit RayCaster::nearest(const Vec3d& origin, const Vec3d& direction, double near_m, double far_m) const {
    RayHit out;
    if (kept_ == 0 || !(length(direction) > 0) || !finite(origin)) return out;
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray = makeRay(origin, direction, centre_, near_m, far_m);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return out;
    // Which triangle Embree reports among several at this very distance
    // depends on its tree; a second, tiny traversal around the distance
    // collects them all and keeps the lowest index.
    const float t = rh.ray.tfar;
    TieContext tie;
    rtcInitIntersectContext(&tie.base);
    tie.base.filter = lowestAtDistance;
    tie.distance = t;
    RTCRayHit again{};
    again.ray = makeRay(origin, direction, centre_, 0, far_m);
    again.ray.tnear = std::nextafter(t, 0.0F);
    again.ray.tfar = std::nextafter(t, std::numeric_limits<float>::infinity());
    again.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &tie.base, &again);
    const uint32_t prim = tie.lowest != UINT32_MAX ? tie.lowest : rh.hit.primID;
    out.hit = true;
    out.distance = t;
    out.triangle = impl_->original[prim];
    return out;
}

}  // namespace cityatlas::atlas
