// SPDX-License-Identifier: GPL-3.0-or-later
#include "cli/progress.h"

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>

#include <fmt/format.h>

namespace cityatlas::cli {

Progress::Progress(bool enabled)
    : enabled_(enabled), tty_(isatty(STDERR_FILENO) != 0), last_(std::chrono::steady_clock::now()) {}

void Progress::update(const char* step, uint64_t done, uint64_t total, bool bytes) {
    if (!enabled_) return;
    const auto now = std::chrono::steady_clock::now();
    const bool new_step = last_step_ != step;
    const bool finished = done >= total;
    // Terminals get 10 redraws a second; logs a line every 5 s, per new step and at the end of a step.
    const auto interval = tty_ ? std::chrono::milliseconds(100) : std::chrono::milliseconds(5000);
    if (!new_step && done == last_done_) return;  // nothing new to say
    if (!new_step && !finished && now - last_ < interval) return;
    last_ = now;
    last_step_ = step;
    last_done_ = done;
    std::string line;
    if (total <= 1) {
        line = fmt::format("{}...", step);
    } else {
        const double fraction = static_cast<double>(done) / static_cast<double>(total);
        const std::string amount = bytes ? fmt::format("{} of {}", humanBytes(done), humanBytes(total))
                                         : fmt::format("{}/{}", done, total);
        std::string bar;
        if (tty_) {
            const int width = 24, filled = static_cast<int>(fraction * width + 0.5);
            bar = fmt::format("[{:#<{}}{:.<{}}] ", "", filled, "", width - filled);
        }
        line = fmt::format("{}: {}{} ({:.0f} %)", step, bar, amount, 100.0 * fraction);
    }
    if (tty_) {
        std::fprintf(stderr, "\r\033[K%s", line.c_str());
        open_line_ = true;
    } else {
        std::fprintf(stderr, "%s\n", line.c_str());
    }
    std::fflush(stderr);
}

void Progress::finish() {
    if (enabled_ && tty_ && open_line_) std::fprintf(stderr, "\r\033[K");
    open_line_ = false;
}

uint64_t peakRssBytes() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return static_cast<uint64_t>(usage.ru_maxrss) * 1024;  // Linux reports KiB
}

std::string humanBytes(uint64_t bytes) {
    if (bytes < 1000) return fmt::format("{} B", bytes);
    const char* units[] = {"kB", "MB", "GB", "TB"};
    double v = static_cast<double>(bytes);
    int u = -1;
    while (v >= 1000 && u < 3) v /= 1000, ++u;
    return fmt::format("{:.1f} {}", v, units[u]);
}

}  // namespace cityatlas::cli
