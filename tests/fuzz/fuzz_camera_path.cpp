// SPDX-License-Identifier: GPL-3.0-or-later
// libFuzzer target for camera paths (render/core/camera_path, `render --path`):
// any bytes give a Status or a path, never a crash, a hang or a sanitizer
// report; a path it accepts keeps the header's promises (times ascending,
// unit directions, fov in range) and can be sampled the way `cityatlas render`
// does (frameCount, sampleFrame) and written back as JSON that parses again.
#include <cmath>
#include <cstdint>
#include <string>

#include "render/core/camera_path.h"
#include "render/core/view.h"
#include "tests/fuzz/fuzz_support.h"

using namespace cityatlas;
using namespace cityatlas::render;

namespace {
void checkSample(const CameraSample& s) {
    // (Positions may overflow to inf between keyframes near 1e308: nothing promises otherwise.)
    if (!(std::abs(length(s.direction) - 1) < 1e-6)) __builtin_trap();
    if (!(s.fov_deg > 1 && s.fov_deg < 170)) __builtin_trap();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    CameraPath path;
    if (!parseCameraPath(text, "fuzz/camera.json", &path).ok()) return 0;
    if (path.keys.empty()) __builtin_trap();
    for (size_t i = 0; i < path.keys.size(); ++i) {
        const CameraKey& k = path.keys[i];
        if (i > 0 && !(k.time_s > path.keys[i - 1].time_s)) __builtin_trap();
        if (!(std::abs(length(k.direction) - 1) < 1e-6)) __builtin_trap();  // "unit"
        if (!(k.fov_deg > 1 && k.fov_deg < 170)) __builtin_trap();
    }
    // As `cityatlas render` plays it: frameCount frames at the path's rate.
    const size_t frames = path.frameCount();
    if (frames == 0) __builtin_trap();
    for (const size_t f : {size_t{0}, frames / 3, frames / 2, frames - 1}) checkSample(sampleFrame(path, f));
    for (const CameraKey& k : path.keys) checkSample(sampleAt(path, k.time_s));
    // Written back, it reads again.
    CameraPath again;
    if (!parseCameraPath(cameraPathToJson(path), "fuzz/again.json", &again).ok()) __builtin_trap();
    if (again.keys.size() != path.keys.size()) __builtin_trap();
    return 0;
}
