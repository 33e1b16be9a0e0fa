// SPDX-License-Identifier: GPL-3.0-or-later
// Camera paths: keyframes are hit exactly, interpolation between them is what
// the schema says, cuts teleport, errors name the keyframe, and the default
// path a new user gets sees the whole town first and ends at eye height.
#include <gtest/gtest.h>

#include <cmath>

#include "render/core/camera_path.h"
#include "render/core/view.h"
#include "tests/render/core/scripted_tree.h"

namespace cityatlas::render {
namespace {

void expectNear(const Vec3d& a, const Vec3d& b, double tol, const std::string& what) {
    EXPECT_NEAR(a.x, b.x, tol) << what;
    EXPECT_NEAR(a.y, b.y, tol) << what;
    EXPECT_NEAR(a.z, b.z, tol) << what;
}

const char* kPath = R"({
  "interpolation": "linear", "frame_rate": 4,
  "keyframes": [
    {"time_s": 0, "position": [0, 0, 10], "direction": [0, 2, 0], "fov_deg": 60, "label": "a"},
    {"time_s": 2, "position": [20, 0, 10], "look_at": [20, 10, 10], "fov_deg": 40},
    {"time_s": 3, "position": [500, 500, 2], "direction": [1, 0, 0], "cut": true, "label": "teleport"}
  ]})";

TEST(CameraPath, ParsesInterpolatesAndCuts) {
    CameraPath p;
    const Status st = parseCameraPath(kPath, "path.json", &p);
    ASSERT_TRUE(st.ok()) << st.error;
    ASSERT_EQ(p.keys.size(), 3u);
    EXPECT_EQ(p.frameCount(), 13u);  // 3 s at 4 fps, both ends
    expectNear(p.keys[0].direction, {0, 1, 0}, 1e-15, "direction normalised");
    expectNear(p.keys[1].direction, {0, 1, 0}, 1e-15, "look_at becomes a direction");
    // Linear: halfway in position and fov.
    CameraSample s = sampleAt(p, 1.0);
    expectNear(s.position, {10, 0, 10}, 1e-12, "midpoint");
    EXPECT_NEAR(s.fov_deg, 50, 1e-12);
    EXPECT_EQ(s.label, "a");
    // Before the cut the camera holds the previous pose; at the cut it is there.
    s = sampleAt(p, 2.99);
    expectNear(s.position, {20, 0, 10}, 1e-12, "hold before the cut");
    s = sampleFrame(p, 12);
    expectNear(s.position, {500, 500, 2}, 1e-12, "after the cut");
    EXPECT_EQ(s.label, "teleport");
    // Catmull-Rom passes through every keyframe, and through evenly spaced collinear keys linearly.
    p.interpolation = Interpolation::CatmullRom;
    for (const CameraKey& k : p.keys) expectNear(sampleAt(p, k.time_s).position, k.position, 1e-9, "keyframe hit");
    CameraPath line;
    ASSERT_TRUE(parseCameraPath(R"({"keyframes": [
        {"time_s": 0, "position": [0,0,0], "direction": [1,0,0]},
        {"time_s": 1, "position": [10,0,0], "direction": [1,0,0]},
        {"time_s": 2, "position": [20,0,0], "direction": [1,0,0]},
        {"time_s": 3, "position": [30,0,0], "direction": [1,0,0]}]})", "line", &line).ok());
    expectNear(sampleAt(line, 1.5).position, {15, 0, 0}, 1e-9, "collinear even spacing");
    // Round trip through JSON.
    CameraPath back;
    ASSERT_TRUE(parseCameraPath(cameraPathToJson(p), "again", &back).ok());
    ASSERT_EQ(back.keys.size(), p.keys.size());
    for (size_t i = 0; i < p.keys.size(); ++i) {
        expectNear(back.keys[i].position, p.keys[i].position, 1e-12, "round trip");
        EXPECT_EQ(back.keys[i].cut, p.keys[i].cut);
    }
}

TEST(CameraPath, ErrorsNameTheKeyframe) {
    const struct {
        const char* text;
        const char* expect;
    } cases[] = {
        {"[1]", "not a JSON object"},
        {R"({"keyframes": []})", "non-empty"},
        {R"({"keyframes": [{"time_s": 1, "position": [0,0,0], "direction": [1,0,0]},
                           {"time_s": 1, "position": [0,0,0], "direction": [1,0,0]}]})", "keyframes[1]: time_s 1 is not after"},
        {R"({"keyframes": [{"time_s": 0, "position": [0,0,0], "direction": [1,0,0], "look_at": [1,1,1]}]})", "exactly one of"},
        {R"({"keyframes": [{"time_s": 0, "position": [0,0,0], "direction": [0,0,0]}]})", "zero length"},
        {R"({"keyframes": [{"time_s": 0, "position": [0,0], "direction": [1,0,0]}]})", "keyframes[0]: \"position\""},
        {R"({"keyframes": [{"time_s": 0, "position": [0,0,0], "direction": [1,0,0], "fov_deg": 180}]})", "fov_deg"},
        {R"({"interpolation": "cubic", "keyframes": []})", "interpolation"},
    };
    for (const auto& c : cases) {
        CameraPath p;
        const Status st = parseCameraPath(c.text, "cam.json", &p);
        ASSERT_FALSE(st.ok()) << c.text;
        EXPECT_NE(st.error.find(c.expect), std::string::npos) << st.error;
        EXPECT_EQ(st.error.rfind("cam.json: ", 0), 0u) << st.error;
    }
}

// Found by fuzz_camera_path: a number beyond double made json::parse throw
// out_of_range, which nothing caught (`render --path` aborted).
TEST(CameraPath, NumberBeyondDoubleIsAnErrorNotAnException) {
    for (const char* text : {"[1e999]", R"({"keyframes": [{"time_s": 1e400, "position": [0,0,0], "direction": [1,0,0]}]})"}) {
        CameraPath p;
        Status st;
        ASSERT_NO_THROW(st = parseCameraPath(text, "cam.json", &p)) << text;
        ASSERT_FALSE(st.ok()) << text;
        EXPECT_EQ(st.error.rfind("cam.json: not JSON", 0), 0u) << st.error;
        EXPECT_EQ(st.error.find('\n'), std::string::npos) << st.error;
        EXPECT_TRUE(p.keys.empty());
    }
}

// Found by fuzz_camera_path: a direction of 1e308s normalized to (0, 0, 0)
// (its length overflows), look_at - position could be infinite, and a time
// span of 1e300 s overflowed frameCount's cast to size_t (undefined behaviour).
TEST(CameraPath, LongDirectionsNormalizeAndHugeSpansDoNotOverflow) {
    CameraPath p;
    ASSERT_TRUE(parseCameraPath(R"({"keyframes": [{"time_s": 0, "position": [0,0,0], "direction": [1e308,1e308,0]}]})",
                                "cam.json", &p)
                    .ok());
    EXPECT_NEAR(p.keys[0].direction.x, std::sqrt(0.5), 1e-12);
    EXPECT_NEAR(p.keys[0].direction.y, std::sqrt(0.5), 1e-12);
    EXPECT_NEAR(length(p.keys[0].direction), 1, 1e-12);

    const Status far = parseCameraPath(
        R"({"keyframes": [{"time_s": 0, "position": [-1e308,0,10], "look_at": [1e308,0,10]}]})", "cam.json", &p);
    ASSERT_FALSE(far.ok());
    EXPECT_NE(far.error.find("keyframes[0]: the view direction is not finite"), std::string::npos) << far.error;

    ASSERT_TRUE(parseCameraPath(R"({"frame_rate": 1000, "keyframes": [
        {"time_s": -1e300, "position": [0,0,10], "direction": [0,1,0]},
        {"time_s": 1e300, "position": [10,0,10], "direction": [0,1,0]}]})",
                                "cam.json", &p)
                    .ok());
    EXPECT_EQ(p.frameCount(), static_cast<size_t>(1e18));
}

TEST(CameraPath, DefaultPathSeesTheTownThenWalksAtEyeHeight) {
    const Box3d town = test::box(-300, -200, 10, 500, 400, 70);
    const CameraPath p = defaultPath(town, 10);
    ASSERT_GE(p.keys.size(), 4u);
    EXPECT_GT(p.frameCount(), 100u);
    // Frame 0: every corner of the town's box is in view.
    const CameraSample s0 = sampleFrame(p, 0);
    Camera cam;
    cam.position = s0.position;
    cam.direction = s0.direction;
    cam.vertical_fov_deg = s0.fov_deg;
    cam.width_px = 1280;
    cam.height_px = 720;
    cam.far_m = 1e6;
    const Frustum f = frustumOf(cam);
    for (int corner = 0; corner < 8; ++corner) {
        const Vec3d p3{corner & 1 ? town.max.x : town.min.x, corner & 2 ? town.max.y : town.min.y,
                       corner & 4 ? town.max.z : town.min.z};
        for (const Plane& pl : f.planes) EXPECT_GE(dot(pl.n, p3) + pl.d, 0) << "corner " << corner;
    }
    EXPECT_EQ(s0.label, "overview");
    // The last frame: at eye height (1.7 m above the box floor), outside the box, street label.
    const CameraSample last = sampleFrame(p, p.frameCount() - 1);
    EXPECT_NEAR(last.position.z, town.min.z + 1.7, 1e-9);
    EXPECT_LT(last.position.y, town.min.y);
    EXPECT_EQ(last.label, "street");
    // Every frame looks at least a little forward and stays out of the ground.
    for (size_t i = 0; i < p.frameCount(); ++i) {
        const CameraSample s = sampleFrame(p, i);
        EXPECT_NEAR(length(s.direction), 1.0, 1e-9);
        EXPECT_GE(s.position.z, town.min.z + 1.7 - 1e-9) << "frame " << i;
    }
}

}  // namespace
}  // namespace cityatlas::render
