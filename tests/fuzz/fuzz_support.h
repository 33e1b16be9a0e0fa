// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Shared by the libFuzzer targets (one translation unit each): sanitizer
// defaults and a scratch folder in memory (/dev/shm) for readers that only
// take a path.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

// A UBSan report is a finding, not a warning to scroll past: stop at the first
// one so libFuzzer keeps the input (the libraries are built with recoverable checks).
extern "C" const char* __ubsan_default_options() { return "halt_on_error=1:print_stacktrace=1"; }

namespace cityatlas::fuzz {

// A per-process scratch folder, in memory when /dev/shm exists (created once).
inline const std::filesystem::path& scratchDir(const char* tag) {
    static const std::filesystem::path dir = [tag] {
        std::error_code ec;
        std::filesystem::path base = "/dev/shm";
        if (!std::filesystem::is_directory(base, ec)) base = std::filesystem::temp_directory_path();
        std::filesystem::path d = base / ("cityatlas_fuzz_" + std::string(tag) + "_" + std::to_string(getpid()));
        std::filesystem::create_directories(d, ec);
        // Gone when the fuzzer exits normally (a crash leaves it for a look).
        static const std::string keep = d.string();
        std::atexit([] {
            std::error_code e;
            std::filesystem::remove_all(keep, e);
        });
        return d;
    }();
    return dir;
}

inline bool writeFile(const std::filesystem::path& path, const void* data, size_t size) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    const bool ok = size == 0 || std::fwrite(data, 1, size, f) == size;
    return std::fclose(f) == 0 && ok;
}

inline uint32_t le32(const uint8_t* p) {
    return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

}  // namespace cityatlas::fuzz
