// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas serve`: hosts a tile folder over HTTP for local use
// (`cityatlas view http://127.0.0.1:8080/`, browser clients) with the static
// server of cli/static_server.h, until SIGINT or SIGTERM.
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <memory>
#include <string>

#include <pthread.h>

#include <fmt/format.h>

#include "cli/commands.h"
#include "cli/outcome.h"
#include "cli/static_server.h"

namespace cityatlas::cli {
namespace {
namespace fs = std::filesystem;

struct ServeCliOptions {
    std::string folder;
    std::string host = "127.0.0.1";
    int port = 8080;
    std::string viewer = CITYATLAS_WEB_DIR;  // the source tree's web/ (compile-time default)
    bool no_viewer = false;
    bool quiet = false;
};

std::string url(const std::string& host, int port) {
    const bool ipv6 = host.find(':') != std::string::npos;
    return ipv6 ? "http://[" + host + "]:" + std::to_string(port) + "/"
                : "http://" + host + ":" + std::to_string(port) + "/";
}

int runServe(const ServeCliOptions& opt) {
    std::error_code ec;
    if (!fs::exists(opt.folder, ec)) {
        return fail("serve", Status::Io(fmt::format("{}: no such folder", opt.folder)));
    }
    const fs::path folder(opt.folder);
    const bool native = fs::is_regular_file(folder / "tileset.json", ec);
    const bool tiles3d = fs::is_regular_file(folder / "3dtiles" / "tileset.json", ec);
    if (!fs::is_directory(folder, ec) || (!native && !tiles3d)) {
        return fail("serve", Status::Invalid(fmt::format(
                                 "{}: not a tile folder (no tileset.json, no 3dtiles/tileset.json)", opt.folder)));
    }
    // The viewer needs its JavaScript packages (npm ci --prefix web) and the 3D Tiles export.
    std::string viewer_note;
    fs::path viewer;
    if (!opt.no_viewer) {
        if (!fs::is_regular_file(fs::path(opt.viewer) / "index.html", ec))
            viewer_note = fmt::format("no viewer: {} has no index.html (--viewer DIR)", opt.viewer);
        else if (!fs::is_regular_file(fs::path(opt.viewer) / "node_modules/three/build/three.module.js", ec))
            viewer_note = fmt::format("no viewer: its packages are not installed (npm ci --prefix {})", opt.viewer);
        else
            viewer = opt.viewer;
        if (!viewer.empty() && !tiles3d) {  // nothing it could show: / stays 404 as without a viewer
            viewer_note = "no viewer: it needs the 3D Tiles export (rebuild with `cityatlas build --format both`)";
            viewer.clear();
        }
    }
    // SIGINT/SIGTERM are taken synchronously below (sigtimedwait), so block
    // them before the server's threads start: those inherit the mask.
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

    StaticServerOptions options;
    options.root = opt.folder;
    options.host = opt.host;
    options.port = opt.port;
    options.log_requests = !opt.quiet;
    options.viewer_root = viewer;
    Status status;
    std::unique_ptr<StaticServer> server = StaticServer::start(options, &status);
    if (!server) {
        return fail("serve", status);
    }
    // The one line on stdout; scripts read the port from it.
    std::printf("serving %s at %s (Ctrl-C stops)\n", opt.folder.c_str(), url(opt.host, server->port()).c_str());
    if (!viewer.empty())
        std::printf("viewer: open %s in a browser (3dtiles/tileset.json: click a building for its attributes)\n",
                    url(opt.host, server->port()).c_str());
    std::fflush(stdout);
    if (!viewer_note.empty() && !opt.quiet) std::fprintf(stderr, "cityatlas serve: note: %s\n", viewer_note.c_str());

    const timespec poll{0, 200 * 1000 * 1000};  // also notice a listener that died on its own
    for (;;) {
        const int sig = sigtimedwait(&stop_signals, nullptr, &poll);
        if (sig == SIGINT || sig == SIGTERM) break;
        if (sig < 0 && errno != EAGAIN && errno != EINTR) break;
        if (!server->running()) {
            return fail("serve", Status::Io(fmt::format("{}: the listener stopped unexpectedly", opt.folder)));
        }
    }
    server->stop();  // finishes the requests in flight
    return kExitOk;
}

}  // namespace

RunFn addServeCommand(CLI::App& app) {
    auto opt = std::make_shared<ServeCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "serve",
        "Serve a tile folder over HTTP for local use (`cityatlas view http://127.0.0.1:8080/`, browser clients).\n"
        "Serves only regular files inside the folder (symlinks resolved; `..` and anything leading outside\n"
        "refused, no folder listings), GET and HEAD, single byte ranges (206/416), keep-alive, CORS\n"
        "(Access-Control-Allow-Origin: *); content types for the tile formats and web files. Files are\n"
        "streamed from disk. Prints one line on stdout once listening: `serving FOLDER at http://HOST:PORT/`.\n"
        "With a 3D Tiles export in the folder (`build --format both` or `3dtiles`) it also serves a web viewer\n"
        "at / (three.js + 3DTilesRendererJS from the viewer folder's npm packages, nothing from the internet):\n"
        "it opens 3dtiles/tileset.json, flies to it, shows load progress and a clicked building's attributes;\n"
        "the second line on stdout gives its URL. The tiles stay at their paths (/tileset.json, /3dtiles/...).\n"
        "SIGINT (Ctrl-C) or SIGTERM stops it (exit 0). Exit 1: not a tile folder, or the address cannot be\n"
        "bound (port in use, not an address of this machine). For production any static web server will do\n"
        "(nginx, a bucket): the folder is plain files.");
    cmd->add_option("folder", opt->folder, "The tile folder (build's -o: tileset.json and/or 3dtiles/tileset.json)")
        ->required();
    cmd->add_option("--port", opt->port, "Port (0: any free one; the line on stdout says which)")
        ->default_val(8080)
        ->check(CLI::Range(0, 65535));
    cmd->add_option("--host", opt->host, "Address to listen on (0.0.0.0 or :: for every interface)")
        ->default_val("127.0.0.1");
    cmd->add_option("--viewer", opt->viewer, "The web viewer's folder (index.html, viewer.js, node_modules)")
        ->default_val(opt->viewer);
    cmd->add_flag("--no-viewer", opt->no_viewer, "Serve the tiles only (nothing at /)");
    cmd->add_flag("-q,--quiet", opt->quiet, "No line per request on stderr (else: client method path status bytes)");
    return [opt]() { return runServe(*opt); };
}

}  // namespace cityatlas::cli
