// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/core/computed_ramp.h"

#include <cmath>

namespace cityatlas::render {

const char* computedModeName(ComputedMode mode) {
    switch (mode) {
        case ComputedMode::Photo: return "photo";
        case ComputedMode::Ramp: return "ramp";
        case ComputedMode::Modulate: return "modulate";
        case ComputedMode::Emphasis: return "emphasis";
    }
    return "?";
}

const std::array<RampColour, 256>& computedRamp() {
    static const std::array<RampColour, 256> ramp = [] {
        struct Stop {
            double at;
            double rgb[3];
        };
        static constexpr Stop kStops[] = {{0.0, {30, 30, 90}}, {1.0 / 3, {40, 120, 140}}, {2.0 / 3, {120, 190, 90}},
                                          {1.0, {250, 230, 80}}};
        std::array<RampColour, 256> r{};
        for (int i = 0; i < 256; ++i) {
            const double v = i / 255.0;
            size_t s = 0;
            while (s + 2 < std::size(kStops) && v > kStops[s + 1].at) ++s;
            const double t = (v - kStops[s].at) / (kStops[s + 1].at - kStops[s].at);
            for (int c = 0; c < 3; ++c)
                r[static_cast<size_t>(i)][static_cast<size_t>(c)] = static_cast<uint8_t>(
                    std::lround(kStops[s].rgb[c] + t * (kStops[s + 1].rgb[c] - kStops[s].rgb[c])));
        }
        return r;
    }();
    return ramp;
}

}  // namespace cityatlas::render
