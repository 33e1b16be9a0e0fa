// SPDX-License-Identifier: GPL-3.0-or-later
// The cityatlas command: the only place that parses argv and picks exit codes.
#include <cstdio>
#include <exception>

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

    RunFn run_synth = addSynthCommand(app);
    RunFn run_ingest = addIngestCommand(app);
    RunFn run_atlas = addAtlasCommand(app);
    RunFn run_build = addBuildCommand(app);
    RunFn run_inspect = addInspectCommand(app);
    RunFn run_render = addRenderCommand(app);
    RunFn run_view = addViewCommand(app);
    RunFn run_serve = addServeCommand(app);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int code = app.exit(e);
        return code == 0 ? kExitOk : kExitUsage;
    }
    try {
        for (CLI::App* sub : app.get_subcommands()) {
            if (sub->get_name() == "synth") return run_synth();
            if (sub->get_name() == "ingest") return run_ingest();
            if (sub->get_name() == "atlas") return run_atlas();
            if (sub->get_name() == "build") return run_build();
            if (sub->get_name() == "inspect") return run_inspect();
            if (sub->get_name() == "render") return run_render();
            if (sub->get_name() == "view") return run_view();
            if (sub->get_name() == "serve") return run_serve();
        }
    } catch (const std::exception& e) {
        // Library code reports expected failures as Status; reaching this is
        // a bug or resource exhaustion, but still gets one line, not a crash.
        std::fprintf(stderr, "cityatlas: error: %s\n", e.what());
        return kExitFailure;
    }
    return kExitUsage;
}
