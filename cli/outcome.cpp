// SPDX-License-Identifier: GPL-3.0-or-later
#include "cli/outcome.h"

#include <cstdio>

#include <fmt/format.h>

namespace cityatlas::cli {

int exitCodeFor(const Status& status) { return status.code == StatusCode::kUsage ? kExitUsage : kExitFailure; }

int fail(const char* command, const Status& status, Progress* progress) {
    if (progress) progress->finish();
    std::fprintf(stderr, "cityatlas %s: error: %s\n", command, status.error.c_str());
    return exitCodeFor(status);
}

void note(const char* command, const std::string& message) {
    std::fprintf(stderr, "cityatlas %s: %s\n", command, message.c_str());
}

void printWarnings(const Diagnostics& diagnostics) {
    if (!diagnostics.total()) return;
    std::printf("Warnings: %llu\n", static_cast<unsigned long long>(diagnostics.total()));
    for (const auto& [code, e] : diagnostics.entries()) {
        const DiagnosticExample& ex = e.examples.front();
        std::printf("  %-24s %6llu  e.g. %s%s%s%s: %s\n", code.c_str(), static_cast<unsigned long long>(e.count),
                    ex.file.c_str(), ex.line ? fmt::format(":{}", ex.line).c_str() : "", ex.gml_id.empty() ? "" : " ",
                    ex.gml_id.c_str(), ex.detail.c_str());
    }
}

}  // namespace cityatlas::cli
