// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Subcommands. Each registers its options on the CLI11 app and returns the
// function that runs it; the function returns the process exit code.

#include <functional>

#include <CLI/CLI.hpp>

namespace cityatlas::cli {

/// Exit codes (documented in README and --help).
enum ExitCode : int { kExitOk = 0, kExitFailure = 1, kExitUsage = 2 };

using RunFn = std::function<int()>;

RunFn addSynthCommand(CLI::App& app);
RunFn addIngestCommand(CLI::App& app);
RunFn addAtlasCommand(CLI::App& app);
RunFn addBuildCommand(CLI::App& app);
RunFn addShardCommand(CLI::App& app);  ///< a sharded build's shard job (cli/shards.h)
RunFn addMergeCommand(CLI::App& app);  ///< a sharded build's merge job
RunFn addInspectCommand(CLI::App& app);
RunFn addRenderCommand(CLI::App& app);
RunFn addViewCommand(CLI::App& app);
RunFn addServeCommand(CLI::App& app);

}  // namespace cityatlas::cli
