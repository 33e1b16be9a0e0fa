// SPDX-License-Identifier: GPL-3.0-or-later
// The static file server behind `cityatlas serve` (see static_server.h).
//
// cpp-httplib 0.11 (Debian 12) routes, parses requests (path percent-decoded,
// Range header parsed, malformed Range answered 416 before any handler) and
// keeps connections alive. We own three things it gets wrong in this version
// (measured): ranges reaching past the end (it sends "bytes 95-200/100", and
// with a content provider a Content-Length it never delivers), unsatisfiable
// ranges with a content provider (206 with a huge Content-Length), and
// multipart ranges with a provider (total "/0"). And its default socket
// options set SO_REUSEPORT, so a second server on a busy port would silently
// share it instead of failing.
#include "cli/static_server.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <string_view>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <netdb.h>
#include <pthread.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>
#include <httplib.h>

namespace cityatlas::cli {
namespace {
namespace fs = std::filesystem;

constexpr size_t kChunkBytes = 64 * 1024;         // one read()/send() piece of a streamed file
constexpr size_t kMaxRequestBodyBytes = 64 * 1024;  // we accept no bodies; refuse big ones early (413)
// A tile client keeps a few connections open and idle between bursts; each
// open connection holds a worker, so allow more than httplib's default 8.
constexpr size_t kWorkerThreads = 16;
constexpr size_t kKeepAliveMaxRequests = 100000;
// httplib 0.11 lets an idle keep-alive connection run out its timeout before
// stop() returns, so this bounds how long Ctrl-C takes; a client idle longer
// reconnects, which costs nothing on loopback.
constexpr time_t kKeepAliveIdleSeconds = 2;

/// An open file of the folder, shared by the response's content provider.
struct OpenFile {
    int fd = -1;
    uint64_t size = 0;
    std::vector<char> buffer;
    ~OpenFile() {
        if (fd >= 0) ::close(fd);
    }
};

enum class Lookup { kFound, kNotFound, kForbidden };

struct LookupResult {
    Lookup result = Lookup::kNotFound;
    fs::path path;                   // canonical, when found
    std::shared_ptr<OpenFile> file;  // open, when found
};

bool isInside(const fs::path& root, const fs::path& candidate) {
    const auto [r, c] = std::mismatch(root.begin(), root.end(), candidate.begin(), candidate.end());
    return r == root.end() && c != candidate.end();
}

// The regular file a (percent-decoded) request path names inside `root`
// (canonical). `..` segments, NUL and paths not starting with '/' (absolute-form
// targets) are refused outright; the rest must still resolve, symlinks
// followed, to a regular file inside the root.
LookupResult openInside(const fs::path& root, const std::string& request_path) {
    if (request_path.empty() || request_path[0] != '/' || request_path.find('\0') != std::string::npos)
        return {Lookup::kForbidden, {}, {}};
    fs::path relative;
    size_t begin = 1;
    while (begin <= request_path.size()) {
        size_t end = request_path.find('/', begin);
        if (end == std::string::npos) end = request_path.size();
        const std::string segment = request_path.substr(begin, end - begin);
        if (segment == "..") return {Lookup::kForbidden, {}, {}};
        if (!segment.empty() && segment != ".") relative /= segment;
        begin = end + 1;
    }
    if (relative.empty()) return {};  // the root itself: no listings
    std::error_code ec;
    const fs::path canonical = fs::canonical(root / relative, ec);
    if (ec) return {};
    if (!isInside(root, canonical)) return {Lookup::kForbidden, {}, {}};
    // Not a regular file (folder, FIFO, device): never opened, so a FIFO cannot hang a worker.
    if (!fs::is_regular_file(canonical, ec)) return {};
    // O_NOFOLLOW: the canonical path has no symlink; one swapped in since is refused.
    const int fd = ::open(canonical.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (fd < 0) return {errno == EACCES ? Lookup::kForbidden : Lookup::kNotFound, {}, {}};
    auto file = std::make_shared<OpenFile>();
    file->fd = fd;
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) return {};
    file->size = static_cast<uint64_t>(st.st_size);
    return {Lookup::kFound, canonical, std::move(file)};
}

enum class RangeKind { kWhole, kPartial, kUnsatisfiable };

struct ByteRange {
    RangeKind kind = RangeKind::kWhole;
    uint64_t first = 0, last = 0;  // inclusive, for kPartial
};

// RFC 9110 §14: one range "a-b", "a-" or "-n" against a file of `size` bytes;
// the end is clipped to the file. Several ranges are ignored (the whole file,
// which the RFC allows): tile clients ask for one.
ByteRange resolveRange(const httplib::Ranges& ranges, uint64_t size) {
    if (ranges.size() != 1) return {};
    const auto [a, b] = ranges.front();  // httplib: -1 for a missing bound
    if (a < 0) {                         // suffix: the last b bytes
        if (b <= 0 || size == 0) return {RangeKind::kUnsatisfiable};
        const uint64_t n = std::min<uint64_t>(static_cast<uint64_t>(b), size);
        return {RangeKind::kPartial, size - n, size - 1};
    }
    if (static_cast<uint64_t>(a) >= size) return {RangeKind::kUnsatisfiable};
    const uint64_t last = b < 0 ? size - 1 : std::min<uint64_t>(static_cast<uint64_t>(b), size - 1);
    return {RangeKind::kPartial, static_cast<uint64_t>(a), last};
}

void plainStatus(httplib::Response& res, int status, const char* text) {
    res.status = status;
    res.set_content(text, "text/plain");
}

void serveFile(const fs::path& root, const std::string& path, const httplib::Request& req, httplib::Response& res) {
    // We answer Range ourselves (see the top of the file). httplib applies
    // req.ranges to every response after the handler, so take them out of the
    // request; it is httplib's own non-const object, passed to us as const.
    const httplib::Ranges ranges = req.ranges;
    const_cast<httplib::Request&>(req).ranges.clear();

    LookupResult found = openInside(root, path);
    if (found.result == Lookup::kForbidden) return plainStatus(res, 403, "forbidden\n");
    if (found.result == Lookup::kNotFound) return plainStatus(res, 404, "not found\n");
    const std::shared_ptr<OpenFile> file = std::move(found.file);
    const char* type = contentTypeFor(found.path);
    res.set_header("Accept-Ranges", "bytes");

    const ByteRange range = resolveRange(ranges, file->size);
    if (range.kind == RangeKind::kUnsatisfiable) {
        res.set_header("Content-Range", fmt::format("bytes */{}", file->size));
        return plainStatus(res, 416, "range not satisfiable\n");
    }
    uint64_t first = 0, length = file->size;
    res.status = 200;
    if (range.kind == RangeKind::kPartial) {
        first = range.first;
        length = range.last - range.first + 1;
        res.status = 206;
        res.set_header("Content-Range", fmt::format("bytes {}-{}/{}", range.first, range.last, file->size));
    }
    if (length == 0) return res.set_content("", type);  // an empty file; httplib sends Content-Length: 0
    file->buffer.resize(static_cast<size_t>(std::min<uint64_t>(length, kChunkBytes)));
    // Streamed: httplib asks for [offset, offset + length) of our `length` bytes
    // until all are written; HEAD never asks.
    res.set_content_provider(
        static_cast<size_t>(length), type, [file, first](size_t offset, size_t wanted, httplib::DataSink& sink) {
            const size_t n = std::min(wanted, file->buffer.size());
            ssize_t got;
            do {
                got = ::pread(file->fd, file->buffer.data(), n, static_cast<off_t>(first + offset));
            } while (got < 0 && errno == EINTR);
            // The file shrank or could not be read: end the response (httplib closes the connection).
            if (got <= 0) return false;
            return sink.write(file->buffer.data(), static_cast<size_t>(got));
        });
}

// The request path as one printable log token: bytes outside printable ASCII
// (a decoded %0a, %00, UTF-8) as %XX.
std::string printable(const std::string& s) {
    std::string out;
    for (const unsigned char c : s) {
        if (c > 0x20 && c < 0x7f && c != '%')
            out += static_cast<char>(c);
        else
            out += fmt::format("%{:02X}", c);
    }
    return out;
}

void logRequest(const httplib::Request& req, const httplib::Response& res) {
    std::string bytes = res.get_header_value("Content-Length");
    if (bytes.empty()) bytes = std::to_string(res.body.size());
    std::fprintf(stderr, "%s %s %s %d %s\n", req.remote_addr.c_str(), req.method.c_str(), printable(req.path).c_str(),
                 res.status, bytes.c_str());
}

// SO_REUSEADDR (restart at once after TIME_WAIT) but not httplib's default
// SO_REUSEPORT: a busy port must make bind fail.
void reuseAddressOnly(socket_t sock) {
    const int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
}

// httplib's bind reports only failure; a plain bind to the same address tells why.
std::string whyBindFails(const std::string& host, int port) {
    addrinfo hints{};
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_PASSIVE;
    addrinfo* found = nullptr;
    const int gai = ::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found);
    if (gai != 0) return fmt::format("cannot resolve the host ({})", ::gai_strerror(gai));
    int error = 0;
    const int fd = ::socket(found->ai_family, found->ai_socktype, found->ai_protocol);
    if (fd < 0) {
        error = errno;
    } else {
        reuseAddressOnly(fd);
        if (::bind(fd, found->ai_addr, found->ai_addrlen) != 0) error = errno;
        ::close(fd);
    }
    ::freeaddrinfo(found);
    switch (error) {
        case 0: return "bind failed (the address was free when checked again; try again)";
        case EADDRINUSE: return "the port is in use";
        case EADDRNOTAVAIL: return "not an address of this machine";
        case EACCES: return "permission denied (ports below 1024 need privileges)";
        default: return std::strerror(error);
    }
}

std::string hostPort(const std::string& host, int port) {
    return host.find(':') != std::string::npos ? fmt::format("[{}]:{}", host, port) : fmt::format("{}:{}", host, port);
}

}  // namespace

const char* contentTypeFor(const fs::path& file) {
    const std::string ext = file.extension().string();
    if (ext == ".json") return "application/json";
    if (ext == ".glb") return "model/gltf-binary";
    if (ext == ".dds") return "image/vnd-ms.dds";
    if (ext == ".bin") return "application/octet-stream";
    if (ext == ".png") return "image/png";
    if (ext == ".html") return "text/html; charset=utf-8";
    if (ext == ".js" || ext == ".mjs") return "text/javascript; charset=utf-8";
    if (ext == ".css") return "text/css; charset=utf-8";
    if (ext == ".wasm") return "application/wasm";
    if (ext == ".map") return "application/json";
    if (ext == ".jpg" || ext == ".jpeg") return "image/jpeg";
    if (ext == ".webp") return "image/webp";
    if (ext == ".ktx2") return "image/ktx2";
    if (ext == ".svg") return "image/svg+xml";
    return "application/octet-stream";
}

struct StaticServer::Impl {
    httplib::Server server;
    std::thread thread;
    std::atomic<bool> finished{false};
    int port = 0;
};

StaticServer::StaticServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

StaticServer::~StaticServer() { stop(); }

int StaticServer::port() const { return impl_->port; }

bool StaticServer::running() const { return !impl_->finished && impl_->server.is_running(); }

void StaticServer::stop() {
    impl_->server.stop();
    if (impl_->thread.joinable()) impl_->thread.join();
}

std::unique_ptr<StaticServer> StaticServer::start(const StaticServerOptions& options, Status* status) {
    std::error_code ec;
    const fs::path root = fs::canonical(options.root, ec);
    if (ec || !fs::is_directory(root, ec)) {
        *status = Status::Io(fmt::format("{}: no such folder", options.root.string()));
        return nullptr;
    }
    auto impl = std::make_unique<Impl>();
    httplib::Server& server = impl->server;
    server.new_task_queue = [] { return new httplib::ThreadPool(kWorkerThreads); };
    server.set_socket_options(reuseAddressOnly);
    server.set_tcp_nodelay(true);  // many small files: send each at once
    server.set_keep_alive_max_count(kKeepAliveMaxRequests);
    server.set_keep_alive_timeout(kKeepAliveIdleSeconds);
    server.set_payload_max_length(kMaxRequestBodyBytes);
    // Browser clients on other origins read tiles and the range headers.
    server.set_default_headers({{"Access-Control-Allow-Origin", "*"},
                                {"Access-Control-Expose-Headers", "Content-Length, Content-Range, Accept-Ranges"}});
    if (options.log_requests) server.set_logger(logRequest);

    fs::path viewer;
    if (!options.viewer_root.empty()) {
        viewer = fs::canonical(options.viewer_root, ec);
        if (ec || !fs::is_regular_file(viewer / "index.html", ec)) {
            *status = Status::Io(fmt::format("{}: not a viewer folder (no index.html)", options.viewer_root.string()));
            return nullptr;
        }
    }
    server.Get(".*", [root, viewer](const httplib::Request& req, httplib::Response& res) {
        // The viewer, when there is one: its page at / and its files under /_viewer/.
        constexpr std::string_view kViewerPrefix = "/_viewer/";
        if (!viewer.empty() && (req.path == "/" || req.path == "/index.html"))
            return serveFile(viewer, "/index.html", req, res);
        if (!viewer.empty() && req.path.rfind(kViewerPrefix, 0) == 0)
            return serveFile(viewer, req.path.substr(kViewerPrefix.size() - 1), req, res);
        serveFile(root, req.path, req, res);
    });
    // HEAD runs the GET handler (httplib); everything else is read-only's 405.
    const auto refuse = [](const httplib::Request&, httplib::Response& res) {
        res.set_header("Allow", "GET, HEAD, OPTIONS");
        plainStatus(res, 405, "method not allowed\n");
    };
    server.Post(".*", refuse);
    server.Put(".*", refuse);
    server.Patch(".*", refuse);
    server.Delete(".*", refuse);
    server.Options(".*", [](const httplib::Request&, httplib::Response& res) {  // CORS preflight (e.g. a suffix Range)
        res.status = 204;
        res.set_header("Allow", "GET, HEAD, OPTIONS");
        res.set_header("Access-Control-Allow-Methods", "GET, HEAD, OPTIONS");
        res.set_header("Access-Control-Allow-Headers", "Range");
        res.set_header("Access-Control-Max-Age", "86400");
    });

    impl->port = options.port == 0 ? server.bind_to_any_port(options.host)
                                   : (server.bind_to_port(options.host, options.port) ? options.port : -1);
    if (impl->port <= 0) {
        *status = Status::Io(fmt::format("cannot listen on {}: {}", hostPort(options.host, options.port),
                                           whyBindFails(options.host, options.port)));
        return nullptr;
    }
    Impl* raw = impl.get();
    raw->thread = std::thread([raw] {
        // Writes to a client that hung up return EPIPE instead of killing the
        // process; the worker threads httplib starts here inherit the mask.
        sigset_t pipe;
        sigemptyset(&pipe);
        sigaddset(&pipe, SIGPIPE);
        pthread_sigmask(SIG_BLOCK, &pipe, nullptr);
        raw->server.listen_after_bind();
        raw->finished = true;
    });
    // stop() does nothing before the listener runs, so wait for it here.
    while (!raw->server.is_running() && !raw->finished) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    if (raw->finished) {
        raw->thread.join();
        *status = Status::Io(fmt::format("cannot listen on {}: the listener stopped at once",
                                           hostPort(options.host, raw->port)));
        return nullptr;
    }
    return std::unique_ptr<StaticServer>(new StaticServer(std::move(impl)));
}

}  // namespace cityatlas::cli
