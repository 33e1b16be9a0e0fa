// SPDX-License-Identifier: GPL-3.0-or-later
#include "cli/outcome.h"

#include <cstdio>

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

}  // namespace cityatlas::cli
