// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Progress on stderr: a redrawn line on a terminal, a line every few seconds
// otherwise (logs, CI), nothing with -q. Thread-safe enough for one caller at
// a time (writers serialise their calls).

#include <chrono>
#include <cstdint>
#include <string>

namespace cityatlas::cli {

class Progress {
public:
    explicit Progress(bool enabled);
    /// `bytes`: done/total are byte counts (shown as MB, with a bar on a terminal).
    void update(const char* step, uint64_t done, uint64_t total, bool bytes = false);
    void finish();  ///< ends a redrawn line

private:
    bool enabled_;
    bool tty_;
    bool open_line_ = false;
    std::string last_step_;
    uint64_t last_done_ = 0;
    std::chrono::steady_clock::time_point last_;
};

/// Peak resident memory of this process so far, in bytes (getrusage).
uint64_t peakRssBytes();

/// "12.3 MB", "512 B": decimal units, as file managers show them.
std::string humanBytes(uint64_t bytes);

}  // namespace cityatlas::cli
