// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// What a stage of a build costs the machine: wall seconds, CPU seconds (this
/// process's threads and the helper processes it has waited for, such as the
/// basisu encoder) and peak resident memory, for the build report's per-stage
/// figures. CPU seconds over wall seconds is the number of cores the stage kept
/// busy on average: the figure that shows serial sections.

#include <chrono>
#include <cstdio>

#include <sys/resource.h>

namespace cityatlas {

/// User + system CPU seconds of this process and of its waited-for children.
inline double processCpuSeconds() {
    auto seconds = [](const rusage& u) {
        return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
               1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
    };
    rusage self{}, children{};
    getrusage(RUSAGE_SELF, &self);
    getrusage(RUSAGE_CHILDREN, &children);
    return seconds(self) + seconds(children);
}

/// Peak resident set size of this process so far, in MB (10^6 bytes, as the CLI prints them).
inline double peakRssMb() {
    // VmHWM is this address space's mark. getrusage's ru_maxrss would carry
    // the mark of the image the process replaced by exec (a sharded `build`
    // becomes `merge --run-shards` after its plan) into every later stage.
    if (std::FILE* f = std::fopen("/proc/self/status", "r")) {
        char line[256];
        long kib = -1;
        while (std::fgets(line, sizeof line, f))
            if (std::sscanf(line, "VmHWM: %ld kB", &kib) == 1) break;
        std::fclose(f);
        if (kib >= 0) return static_cast<double>(kib) * 1024.0 / 1e6;
    }
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<double>(u.ru_maxrss) * 1024.0 / 1e6;  // Linux reports KiB
}

struct StageCost {
    double seconds = 0;       ///< wall
    double cpu_seconds = 0;   ///< user + system, this process and its helpers
    double peak_rss_mb = 0;   ///< at the stage's end
    double coresBusy() const { return seconds > 0 ? cpu_seconds / seconds : 0; }
};

/// Laps of a build: each lap() is the cost since the previous one (or since construction).
class StageClock {
public:
    StageCost lap() {
        const auto now = std::chrono::steady_clock::now();
        const double cpu = processCpuSeconds();
        StageCost c{std::chrono::duration<double>(now - wall_).count(), cpu - cpu_, peakRssMb()};
        wall_ = now, cpu_ = cpu;
        return c;
    }

private:
    std::chrono::steady_clock::time_point wall_ = std::chrono::steady_clock::now();
    double cpu_ = processCpuSeconds();
};

}  // namespace cityatlas
