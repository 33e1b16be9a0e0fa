// SPDX-License-Identifier: GPL-3.0-or-later
// (in progress)
#include "cli/commands.h"
namespace cityatlas::cli {
RunFn addInspectCommand(CLI::App& app) {
    app.add_subcommand("inspect", "(in progress)");
    return [] { return 1; };
}
}  // namespace cityatlas::cli
