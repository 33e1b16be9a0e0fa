// SPDX-License-Identifier: GPL-3.0-or-later
// The cityatlas command: the only place that parses argv and picks exit codes.
#include <cstdio>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "cityatlas_version.h"
#include "cli/commands.h"

int main(int argc, char** argv) {
    using namespace cityatlas::cli;
    CLI::App app{"cityatlas: municipal 3D city data (CityGML LOD1/LOD2, attributed footprints) to streamable\n"
                 "texture-atlas city tiles.\n\n"
                 "Exit codes: 0 success, 1 failure (bad input, I/O; one line on stderr says what and where),\n"
                 "2 usage error.",
                 "cityatlas"};
    app.set_version_flag("--version", std::string("cityatlas ") + kCityAtlasVersion);
    app.require_subcommand(1);
    app.fallthrough(false);

    // The pipeline's commands exist in the full build only (CITYATLAS_PIPELINE);
    // cityatlas-client has the client's.
    std::vector<std::pair<std::string, RunFn>> commands;
#ifdef CITYATLAS_WITH_PIPELINE
    commands.emplace_back("synth", addSynthCommand(app));
    commands.emplace_back("ingest", addIngestCommand(app));
    commands.emplace_back("atlas", addAtlasCommand(app));
    commands.emplace_back("build", addBuildCommand(app));
    commands.emplace_back("shard", addShardCommand(app));
    commands.emplace_back("merge", addMergeCommand(app));
    commands.emplace_back("inspect", addInspectCommand(app));
#endif
    commands.emplace_back("render", addRenderCommand(app));
    commands.emplace_back("view", addViewCommand(app));
    commands.emplace_back("serve", addServeCommand(app));

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? kExitOk : kExitUsage;
    }
    try {
        for (CLI::App* sub : app.get_subcommands())
            for (const auto& [name, run] : commands)
                if (sub->get_name() == name) return run();
    } catch (const std::exception& e) {
        // Library code reports expected failures as Status; reaching this is
        // a bug or resource exhaustion, but still gets one line, not a crash.
        std::fprintf(stderr, "cityatlas: error: %s\n", e.what());
        return kExitFailure;
    }
    return kExitUsage;
}
