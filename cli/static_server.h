// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// A minimal static file server (Boost.Beast over Asio) for a tile folder, used by
// `cityatlas serve` (local viewing, browser clients). It serves only regular
// files inside the root once symlinks are resolved, with the tile formats'
// content types, single byte ranges, HEAD, keep-alive and CORS; files are
// streamed from disk in 64 KiB pieces, never read whole into memory. Every
// request read whole is answered, also on a socket the client half-closed.
// Production hosting is any static web server: a tile folder is plain files.

#include <filesystem>
#include <memory>
#include <string>

#include "core/status.h"

namespace cityatlas::cli {

struct StaticServerOptions {
    std::filesystem::path root;  ///< the folder served; nothing outside it is
    std::string host = "127.0.0.1";
    int port = 8080;            ///< 0: any free port (port() says which)
    bool log_requests = false;  ///< one line per request on stderr
    /// A web viewer's folder (holding index.html): served at / and under
    /// /_viewer/, with the same rules as the root. Empty: none.
    std::filesystem::path viewer_root;
};

/// Serves in threads of its own (2 to 8, by the core count; connections are
/// asynchronous, so an idle one holds no thread) from start() until stop()
/// or destruction.
/// The serving threads block SIGPIPE (a client that hangs up is an error
/// return, not a dead process); they inherit the caller's other signal mask,
/// so a caller that waits for SIGINT/SIGTERM blocks them before start().
class StaticServer {
public:
    /// Binds and starts serving; null with `status` set (one line naming the
    /// address and why: port in use, not an address of this machine, ...).
    static std::unique_ptr<StaticServer> start(const StaticServerOptions& options, Status* status);

    int port() const;      ///< the port bound (the free one chosen for port 0)
    bool running() const;  ///< false once stopped or if the listener failed
    void stop();           ///< stops accepting, finishes open requests, joins
    ~StaticServer();

    StaticServer(const StaticServer&) = delete;
    StaticServer& operator=(const StaticServer&) = delete;

private:
    struct Impl;
    explicit StaticServer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

/// The Content-Type sent for a file name (by extension, case-sensitive as the
/// tile writer names them); application/octet-stream when unknown.
const char* contentTypeFor(const std::filesystem::path& file);

}  // namespace cityatlas::cli
