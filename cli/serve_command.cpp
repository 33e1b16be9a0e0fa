// SPDX-License-Identifier: GPL-3.0-or-later
// `cityatlas serve`: a minimal static file server (cpp-httplib) for a tile
// folder, for local use: `cityatlas view http://127.0.0.1:8080/` or a browser
// client. Serves only files inside the folder (symlinks resolved), with the
// tile formats' content types, Range requests, keep-alive and CORS.
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>
#include <httplib.h>

#include "cli/commands.h"

namespace cityatlas::cli {
namespace {
namespace fs = std::filesystem;

struct ServeCliOptions {
    std::string folder;
    std::string host = "127.0.0.1";
    int port = 8080;
    bool quiet = false;
};

httplib::Server* g_server = nullptr;

void stopOnSignal(int) {
    if (g_server) g_server->stop();
}

const char* contentType(const fs::path& p) {
    const std::string ext = p.extension().string();
    if (ext == ".json") return "application/json";
    if (ext == ".glb") return "model/gltf-binary";
    if (ext == ".dds") return "image/vnd-ms.dds";
    if (ext == ".png") return "image/png";
    if (ext == ".html") return "text/html";
    return "application/octet-stream";
}

// The file a request path names, if it lies inside `root` once symlinks and
// dot segments are resolved; empty otherwise.
fs::path resolveInside(const fs::path& root, const std::string& request_path) {
    if (request_path.empty() || request_path[0] != '/' || request_path.find('\0') != std::string::npos) return {};
    std::error_code ec;
    const fs::path candidate = fs::weakly_canonical(root / request_path.substr(1), ec);
    if (ec) return {};
    const std::string r = root.string(), c = candidate.string();
    if (c.size() <= r.size() || c.compare(0, r.size(), r) != 0 || c[r.size()] != '/') return {};
    if (!fs::is_regular_file(candidate, ec)) return {};
    return candidate;
}

// cpp-httplib binds with SO_REUSEPORT, so a second server on a busy port would
// silently share it. A plain bind first tells whether the port is free.
bool portInUse(const std::string& host, int port) {
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) return false;  // not IPv4: let httplib decide
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) return false;
    const bool busy = ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 && errno == EADDRINUSE;
    ::close(fd);
    return busy;
}

int runServe(const ServeCliOptions& opt) {
    std::error_code ec;
    if (!fs::is_directory(opt.folder, ec)) {
        std::fprintf(stderr, "cityatlas serve: %s: no such folder\n", opt.folder.c_str());
        return kExitFailure;
    }
    if (!fs::exists(fs::path(opt.folder) / "tileset.json", ec)) {
        std::fprintf(stderr, "cityatlas serve: %s: not a tile folder (no tileset.json)\n", opt.folder.c_str());
        return kExitFailure;
    }
    if (opt.port != 0 && portInUse(opt.host, opt.port)) {
        std::fprintf(stderr, "cityatlas serve: cannot listen on %s:%d: the port is in use\n", opt.host.c_str(), opt.port);
        return kExitFailure;
    }
    const fs::path root = fs::canonical(opt.folder, ec);
    httplib::Server server;
    // A tile client asks for many small files: keep connections open, send at once.
    server.set_keep_alive_max_count(100000);
    server.set_tcp_nodelay(true);
    server.set_default_headers({{"Access-Control-Allow-Origin", "*"}});
    const bool log = !opt.quiet;
    auto handler = [&root, log](const httplib::Request& req, httplib::Response& res) {
        const fs::path file = resolveInside(root, req.path);
        if (file.empty()) {
            res.status = 404;
            res.set_content("not found\n", "text/plain");
        } else {
            std::ifstream f(file, std::ios::binary);
            std::string body((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
            res.set_content(std::move(body), contentType(file));  // httplib applies Range requests to it
        }
        if (log) std::fprintf(stderr, "%s %s %d\n", req.method.c_str(), req.path.c_str(), res.status);
    };
    server.Get(".*", handler);
    const int port = opt.port == 0 ? server.bind_to_any_port(opt.host) : (server.bind_to_port(opt.host, opt.port) ? opt.port : -1);
    if (port <= 0) {
        std::fprintf(stderr, "cityatlas serve: cannot listen on %s:%d (in use, or not an address of this machine)\n",
                     opt.host.c_str(), opt.port);
        return kExitFailure;
    }
    g_server = &server;
    std::signal(SIGINT, stopOnSignal);
    std::signal(SIGTERM, stopOnSignal);
    std::printf("serving %s at http://%s:%d/ (Ctrl-C stops)\n", opt.folder.c_str(), opt.host.c_str(), port);
    std::fflush(stdout);
    server.listen_after_bind();
    g_server = nullptr;
    return kExitOk;
}

}  // namespace

RunFn addServeCommand(CLI::App& app) {
    auto opt = std::make_shared<ServeCliOptions>();
    CLI::App* cmd = app.add_subcommand(
        "serve",
        "Serve a tile folder over HTTP for local use (`cityatlas view http://127.0.0.1:8080/`, browser clients):\n"
        "only files inside the folder, tile content types, Range requests, keep-alive, CORS. For production, any\n"
        "static web server will do (nginx, a bucket): the folder is plain files.");
    cmd->add_option("folder", opt->folder, "The tile folder (holding tileset.json)")->required();
    cmd->add_option("--port", opt->port, "Port (0: any free one; the line on stdout says which)")
        ->default_val(8080)
        ->check(CLI::Range(0, 65535));
    cmd->add_option("--host", opt->host, "Address to listen on")->default_val("127.0.0.1");
    cmd->add_flag("-q,--quiet", opt->quiet, "No line per request on stderr");
    return [opt]() { return runServe(*opt); };
}

}  // namespace cityatlas::cli
