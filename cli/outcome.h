// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// How every command reports: one prefix for errors and notes
// ("cityatlas <command>: error: ...", "cityatlas <command>: ..."), one exit
// code per StatusCode (usage 2, every other failure 1). The summary of the
// readers' counted warnings is printWarnings() (cli/scene_input.h).

#include <string>

#include "cli/commands.h"
#include "cli/progress.h"
#include "core/status.h"

namespace cityatlas::cli {

/// The exit code for a failed status: kExitUsage for StatusCode::kUsage, else kExitFailure.
int exitCodeFor(const Status& status);

/// Ends the progress line (when given), prints
/// "cityatlas <command>: error: <message>" on stderr and returns exitCodeFor().
int fail(const char* command, const Status& status, Progress* progress = nullptr);

/// A note on stderr that is not a failure: "cityatlas <command>: <message>".
void note(const char* command, const std::string& message);

}  // namespace cityatlas::cli
