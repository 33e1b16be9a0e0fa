// SPDX-License-Identifier: GPL-3.0-or-later
// The static file server behind `cityatlas serve` (see static_server.h).
//
// Boost.Beast parses and writes HTTP/1.1 (request grammar, keep-alive and
// HTTP/1.0 rules, header and body limits) over Boost.Asio sockets: a few
// threads, one strand per connection, so an idle or slow connection holds a
// socket, never a thread. We own the file lookup (nothing outside the root),
// Range (RFC 9110 §14: one range, clipped to the file), the timeouts and the
// closing handshake.
//
// Why not cpp-httplib, which served here until stop 26: its 0.11 (Debian 12)
// checks writability by peeking the socket before every write and takes a
// peer that has shut down its write side (EOF) for gone, so a client that
// sends its request and then half-closes (RFC 9112 §9.6 allows it; nginx
// answers it) got nothing: 6 of 269 answered in benchmarks/serve_load.sh.
// Here a request that was read completely is always answered.
#include "cli/static_server.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <optional>
#include <string_view>
#include <thread>
#include <type_traits>
#include <vector>

#include <fcntl.h>
#include <pthread.h>
#include <sys/stat.h>
#include <unistd.h>

#include <boost/asio/dispatch.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <fmt/format.h>

namespace cityatlas::cli {
namespace {
namespace fs = std::filesystem;
namespace beast = boost::beast;
namespace http = boost::beast::http;
namespace net = boost::asio;
using tcp = boost::asio::ip::tcp;
using namespace std::chrono_literals;

constexpr size_t kChunkBytes = 64 * 1024;           // one pread()/send() piece of a streamed file
constexpr size_t kMaxRequestBodyBytes = 64 * 1024;  // we accept no bodies; refuse big ones early (413)
constexpr size_t kMaxHeaderBytes = 16 * 1024;       // request line + fields; more is refused (431)
// A keep-alive connection idle this long is closed, and a request must arrive
// whole within it; it also bounds how long stop() waits for idle clients.
constexpr auto kIdle = 2s;
// A client that takes none of a response's bytes for this long is dropped.
constexpr auto kSendStall = 30s;
// After our last byte we read (and drop) what the client still sends, for at
// most this long, before closing: closing a socket with unread bytes sends a
// reset, which can destroy the answer before the client has read it.
constexpr auto kLinger = 1s;

/// An open file of the folder, shared by the response that streams it.
struct OpenFile {
    int fd = -1;
    uint64_t size = 0;
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
// targets, '*') are refused outright; the rest must still resolve, symlinks
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

// The path of an origin-form request target, percent-decoded (the query is
// dropped); nullopt for a malformed escape. Other forms come back as they are
// and are refused by openInside (they do not start with '/').
std::optional<std::string> decodeTargetPath(std::string_view target) {
    target = target.substr(0, target.find('?'));
    std::string out;
    out.reserve(target.size());
    const auto hex = [](char c) -> int {
        if (c >= '0' && c <= '9') return c - '0';
        if (c >= 'a' && c <= 'f') return c - 'a' + 10;
        if (c >= 'A' && c <= 'F') return c - 'A' + 10;
        return -1;
    };
    for (size_t i = 0; i < target.size(); ++i) {
        if (target[i] != '%') {
            out += target[i];
            continue;
        }
        if (i + 2 >= target.size()) return std::nullopt;
        const int hi = hex(target[i + 1]), lo = hex(target[i + 2]);
        if (hi < 0 || lo < 0) return std::nullopt;
        out += static_cast<char>(hi * 16 + lo);
        i += 2;
    }
    return out;
}

enum class RangeKind { kWhole, kPartial, kUnsatisfiable };

struct ByteRange {
    RangeKind kind = RangeKind::kWhole;
    uint64_t first = 0, last = 0;  // inclusive, for kPartial
};

// A decimal position; a number beyond 64 bits reads as the largest one (it
// lies past any file). False when `s` is not all digits or empty.
bool parsePosition(std::string_view s, uint64_t* value) {
    if (s.empty()) return false;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), *value);
    if (end != s.data() + s.size()) return false;
    if (ec == std::errc::result_out_of_range) *value = UINT64_MAX;
    return ec == std::errc() || ec == std::errc::result_out_of_range;
}

std::string_view trimmed(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
    return s;
}

// RFC 9110 §14: a Range header with one range "a-b", "a-" or "-n" against a
// file of `size` bytes; the end is clipped to the file. Several ranges, other
// units and malformed ones are ignored (the whole file, which the RFC allows):
// tile clients ask for one.
ByteRange resolveRange(std::string_view header, uint64_t size) {
    header = trimmed(header);
    constexpr std::string_view kUnit = "bytes=";
    if (header.size() <= kUnit.size() || !beast::iequals(beast::string_view(header.data(), kUnit.size()), beast::string_view(kUnit.data(), kUnit.size()))) return {};
    const std::string_view spec = trimmed(header.substr(kUnit.size()));
    const size_t dash = spec.find('-');
    if (spec.find(',') != std::string_view::npos || dash == std::string_view::npos) return {};
    const std::string_view a = spec.substr(0, dash), b = spec.substr(dash + 1);
    uint64_t first = 0, last = 0;
    if (a.empty()) {  // suffix: the last b bytes
        if (!parsePosition(b, &last)) return {};
        if (last == 0 || size == 0) return {RangeKind::kUnsatisfiable};
        return {RangeKind::kPartial, size - std::min(last, size), size - 1};
    }
    if (!parsePosition(a, &first)) return {};
    if (b.empty()) {
        last = UINT64_MAX;
    } else if (!parsePosition(b, &last) || last < first) {
        return {};
    }
    if (first >= size) return {RangeKind::kUnsatisfiable};
    return {RangeKind::kPartial, first, std::min(last, size - 1)};
}

/// A Beast body that streams bytes [first, first + length) of an open file in
/// kChunkBytes pieces (pread: responses never share a file offset).
struct FileRangeBody {
    struct value_type {
        std::shared_ptr<OpenFile> file;
        uint64_t first = 0, length = 0;
    };
    static uint64_t size(const value_type& body) { return body.length; }

    class writer {
    public:
        using const_buffers_type = net::const_buffer;
        template <bool isRequest, class Fields>
        writer(const http::header<isRequest, Fields>&, const value_type& body) : body_(body) {}
        void init(beast::error_code& ec) { ec = {}; }
        boost::optional<std::pair<const_buffers_type, bool>> get(beast::error_code& ec) {
            ec = {};
            const uint64_t left = body_.length - sent_;
            if (left == 0) return boost::none;
            buffer_.resize(static_cast<size_t>(std::min<uint64_t>(left, kChunkBytes)));
            ssize_t got;
            do {
                got = ::pread(body_.file->fd, buffer_.data(), buffer_.size(), static_cast<off_t>(body_.first + sent_));
            } while (got < 0 && errno == EINTR);
            if (got <= 0) {  // the file shrank or cannot be read: the response ends short, the connection closes
                ec = boost::system::errc::make_error_code(boost::system::errc::io_error);
                return boost::none;
            }
            sent_ += static_cast<uint64_t>(got);
            return std::make_pair(net::const_buffer(buffer_.data(), static_cast<size_t>(got)), sent_ < body_.length);
        }

    private:
        const value_type& body_;
        uint64_t sent_ = 0;
        std::vector<char> buffer_;
    };
};

// The request path as one printable log token: bytes outside printable ASCII
// (a decoded %0a, %00, UTF-8) as %XX.
std::string printable(std::string_view s) {
    std::string out;
    for (const unsigned char c : s) {
        if (c > 0x20 && c < 0x7f && c != '%')
            out += static_cast<char>(c);
        else
            out += fmt::format("%{:02X}", c);
    }
    return out;
}

std::string str(beast::string_view s) { return std::string(s.data(), s.size()); }

std::string hostPort(const std::string& host, int port) {
    return host.find(':') != std::string::npos ? fmt::format("[{}]:{}", host, port) : fmt::format("{}:{}", host, port);
}

std::string whyBindFails(const boost::system::error_code& ec) {
    switch (ec.value()) {
        case EADDRINUSE: return "the port is in use";
        case EADDRNOTAVAIL: return "not an address of this machine";
        case EACCES: return "permission denied (ports below 1024 need privileges)";
        default: return ec.message();
    }
}

/// What every connection of one server shares.
struct Site {
    fs::path root;
    fs::path viewer;  // empty: none
    bool log_requests = false;
};

/// One connection: read a request, answer it, again while keep-alive holds;
/// all on the connection's strand.
class Connection : public std::enable_shared_from_this<Connection> {
public:
    Connection(tcp::socket socket, std::shared_ptr<Site> site) : stream_(std::move(socket)), site_(std::move(site)) {
        beast::error_code ec;
        const tcp::endpoint peer = stream_.socket().remote_endpoint(ec);
        peer_ = ec ? "-" : peer.address().to_string();
    }
    void start() {
        net::dispatch(stream_.get_executor(), [self = shared_from_this()] { self->readRequest(); });
    }

private:
    template <class Body>
    struct Outgoing {
        explicit Outgoing(http::response<Body>&& r) : response(std::move(r)), serializer(response) {}
        http::response<Body> response;
        http::response_serializer<Body> serializer;
    };

    void readRequest() {
        parser_.emplace();
        parser_->header_limit(static_cast<std::uint32_t>(kMaxHeaderBytes));
        parser_->body_limit(kMaxRequestBodyBytes);
        stream_.expires_after(kIdle);
        http::async_read(stream_, buffer_, *parser_,
                         [self = shared_from_this()](beast::error_code ec, size_t) { self->onRequest(ec); });
    }

    void onRequest(beast::error_code ec) {
        // The client closed or shut down its side between requests, or stayed idle: done.
        if (ec == http::error::end_of_stream) return finish();
        if (ec == beast::error::timeout || ec == http::error::partial_message) return close();
        keep_alive_ = false;
        head_request_ = false;
        if (ec == http::error::header_limit) return sendText(http::status::request_header_fields_too_large, "-", "-",
                                                             "request header fields too large\n");
        if (ec == http::error::body_limit) return sendText(http::status::payload_too_large, "-", "-", "payload too large\n");
        if (ec && ec.category() == http::make_error_code(http::error::bad_target).category())
            return sendText(http::status::bad_request, "-", "-", "bad request\n");
        if (ec) return close();

        const http::request<http::string_body>& req = parser_->get();
        keep_alive_ = req.keep_alive();
        head_request_ = req.method() == http::verb::head;
        version_ = req.version();
        const std::string method = str(req.method_string());
        const std::string target = str(req.target());
        const std::optional<std::string> path = decodeTargetPath(target);
        if (!path) return sendText(http::status::bad_request, method, target, "bad request\n");
        switch (req.method()) {
            case http::verb::get:
            case http::verb::head: return route(req, *path);
            case http::verb::options: {  // CORS preflight (e.g. a suffix Range)
                http::response<http::empty_body> res{http::status::no_content, version_};
                res.set(http::field::allow, "GET, HEAD, OPTIONS");
                res.set(http::field::access_control_allow_methods, "GET, HEAD, OPTIONS");
                res.set(http::field::access_control_allow_headers, "Range");
                res.set(http::field::access_control_max_age, "86400");
                return send(std::move(res), method, *path, 0);
            }
            default: {  // read-only
                http::response<http::string_body> res = text(http::status::method_not_allowed, "method not allowed\n");
                res.set(http::field::allow, "GET, HEAD, OPTIONS");
                return send(std::move(res), method, *path, res.body().size());
            }
        }
    }

    // The viewer, when there is one: its page at / and its files under /_viewer/.
    void route(const http::request<http::string_body>& req, const std::string& path) {
        constexpr std::string_view kViewerPrefix = "/_viewer/";
        if (!site_->viewer.empty() && (path == "/" || path == "/index.html"))
            return serveFile(site_->viewer, "/index.html", req, path);
        if (!site_->viewer.empty() && path.rfind(kViewerPrefix, 0) == 0)
            return serveFile(site_->viewer, path.substr(kViewerPrefix.size() - 1), req, path);
        serveFile(site_->root, path, req, path);
    }

    void serveFile(const fs::path& root, const std::string& file_path, const http::request<http::string_body>& req,
                   const std::string& logged_path) {
        const std::string method = str(req.method_string());
        LookupResult found = openInside(root, file_path);
        if (found.result == Lookup::kForbidden) return sendText(http::status::forbidden, method, logged_path, "forbidden\n");
        if (found.result == Lookup::kNotFound) return sendText(http::status::not_found, method, logged_path, "not found\n");
        const uint64_t size = found.file->size;
        const ByteRange range = resolveRange(str(req[http::field::range]), size);
        if (range.kind == RangeKind::kUnsatisfiable) {
            http::response<http::string_body> res = text(http::status::range_not_satisfiable, "range not satisfiable\n");
            res.set(http::field::content_range, fmt::format("bytes */{}", size));
            res.set(http::field::accept_ranges, "bytes");
            return send(std::move(res), method, logged_path, res.body().size());
        }
        uint64_t first = 0, length = size;
        http::status status = http::status::ok;
        std::string content_range;
        if (range.kind == RangeKind::kPartial) {
            first = range.first;
            length = range.last - range.first + 1;
            status = http::status::partial_content;
            content_range = fmt::format("bytes {}-{}/{}", range.first, range.last, size);
        }
        const auto fill = [&](auto& res) {
            res.set(http::field::content_type, contentTypeFor(found.path));
            res.set(http::field::accept_ranges, "bytes");
            if (!content_range.empty()) res.set(http::field::content_range, content_range);
            res.content_length(length);
        };
        if (req.method() == http::verb::head) {  // the headers a GET would send, no body
            http::response<http::empty_body> res{status, version_};
            fill(res);
            return send(std::move(res), method, logged_path, length);
        }
        http::response<FileRangeBody> res{status, version_};
        fill(res);
        res.body() = FileRangeBody::value_type{std::move(found.file), first, length};
        send(std::move(res), method, logged_path, length);
    }

    http::response<http::string_body> text(http::status status, const char* body) const {
        http::response<http::string_body> res{status, version_};
        res.set(http::field::content_type, "text/plain");
        res.body() = body;
        res.prepare_payload();
        return res;
    }

    void sendText(http::status status, const std::string& method, const std::string& path, const char* body) {
        http::response<http::string_body> res = text(status, body);
        const size_t bytes = res.body().size();
        send(std::move(res), method, path, bytes);
    }

    template <class Body>
    void send(http::response<Body>&& res, const std::string& method, const std::string& path, uint64_t bytes) {
        // A response to HEAD is the headers alone (a 404's text too): a body
        // there would be read as the start of the next response.
        if constexpr (!std::is_same_v<Body, http::empty_body>) {
            if (head_request_) {
                http::response<http::empty_body> headers_only(std::move(res.base()));
                return send(std::move(headers_only), method, path, bytes);
            }
        }
        // Browser clients on other origins read tiles and the range headers.
        res.set(http::field::access_control_allow_origin, "*");
        res.set(http::field::access_control_expose_headers, "Content-Length, Content-Range, Accept-Ranges");
        res.keep_alive(keep_alive_);
        if (site_->log_requests)
            std::fprintf(stderr, "%s %s %s %u %llu\n", peer_.c_str(), method.c_str(), printable(path).c_str(),
                         res.result_int(), static_cast<unsigned long long>(bytes));
        writeSome(std::make_shared<Outgoing<Body>>(std::move(res)));
    }

    // One write at a time, so a stalled client is dropped after kSendStall
    // without a bound on how long a large file may take.
    template <class Body>
    void writeSome(std::shared_ptr<Outgoing<Body>> out) {
        stream_.expires_after(kSendStall);
        http::async_write_some(stream_, out->serializer, [self = shared_from_this(), out](beast::error_code ec, size_t) {
            if (ec) return self->close();
            if (!out->serializer.is_done()) return self->writeSome(out);
            if (out->response.need_eof()) return self->finish();
            self->readRequest();
        });
    }

    // Our side is done: FIN, then read and drop until the client closes too.
    void finish() {
        beast::error_code ignored;
        stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
        stream_.expires_after(kLinger);
        drain();
    }

    void drain() {
        stream_.async_read_some(net::buffer(drain_), [self = shared_from_this()](beast::error_code ec, size_t) {
            if (ec) return self->close();
            self->drain();
        });
    }

    void close() {
        beast::error_code ignored;
        stream_.socket().close(ignored);
    }

    beast::tcp_stream stream_;
    std::shared_ptr<Site> site_;
    std::string peer_;
    beast::flat_buffer buffer_;
    std::optional<http::request_parser<http::string_body>> parser_;
    bool keep_alive_ = false;
    bool head_request_ = false;
    unsigned version_ = 11;
    std::array<char, 4096> drain_{};
};

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
    net::io_context io;
    tcp::acceptor acceptor{net::make_strand(io)};  // accepts, retries and stop() on one strand
    net::steady_timer retry{acceptor.get_executor()};  // after a failed accept (out of descriptors): a pause, not a busy loop
    std::shared_ptr<Site> site = std::make_shared<Site>();
    std::vector<std::thread> threads;
    std::atomic<int> threads_running{0};
    std::atomic<bool> stopping{false};
    int port = 0;

    void accept() {
        acceptor.async_accept(net::make_strand(io), [this](beast::error_code ec, tcp::socket socket) {
            if (!acceptor.is_open()) return;  // stop()
            if (ec) {
                retry.expires_after(50ms);
                retry.async_wait([this](beast::error_code) { accept(); });
                return;
            }
            beast::error_code ignored;
            socket.set_option(tcp::no_delay(true), ignored);  // many small files: send each at once
            std::make_shared<Connection>(std::move(socket), site)->start();
            accept();
        });
    }
};

StaticServer::StaticServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

StaticServer::~StaticServer() { stop(); }

int StaticServer::port() const { return impl_->port; }

bool StaticServer::running() const { return !impl_->stopping && impl_->threads_running > 0; }

void StaticServer::stop() {
    if (impl_->threads.empty()) return;
    impl_->stopping = true;
    net::post(impl_->acceptor.get_executor(), [impl = impl_.get()] {
        beast::error_code ignored;
        impl->acceptor.close(ignored);
        impl->retry.cancel();
    });
    // Responses in flight finish and idle connections close within kIdle;
    // past that (a client that stopped reading) the rest are dropped.
    const auto deadline = std::chrono::steady_clock::now() + kIdle + kLinger + 1s;
    while (impl_->threads_running > 0 && std::chrono::steady_clock::now() < deadline)
        std::this_thread::sleep_for(10ms);
    impl_->io.stop();
    for (std::thread& t : impl_->threads) t.join();
    impl_->threads.clear();
}

std::unique_ptr<StaticServer> StaticServer::start(const StaticServerOptions& options, Status* status) {
    std::error_code ec;
    const fs::path root = fs::canonical(options.root, ec);
    if (ec || !fs::is_directory(root, ec)) {
        *status = Status::Io(fmt::format("{}: no such folder", options.root.string()));
        return nullptr;
    }
    auto impl = std::make_unique<Impl>();
    impl->site->root = root;
    impl->site->log_requests = options.log_requests;
    if (!options.viewer_root.empty()) {
        impl->site->viewer = fs::canonical(options.viewer_root, ec);
        if (ec || !fs::is_regular_file(impl->site->viewer / "index.html", ec)) {
            *status = Status::Io(fmt::format("{}: not a viewer folder (no index.html)", options.viewer_root.string()));
            return nullptr;
        }
    }

    const std::string where = hostPort(options.host, options.port);
    beast::error_code bec;
    tcp::resolver resolver(impl->io);
    const auto found = resolver.resolve(options.host, std::to_string(options.port), tcp::resolver::passive, bec);
    if (bec || found.empty()) {
        *status = Status::Io(fmt::format("cannot listen on {}: cannot resolve the host ({})", where, bec.message()));
        return nullptr;
    }
    const tcp::endpoint endpoint = found.begin()->endpoint();
    tcp::acceptor& acceptor = impl->acceptor;
    // SO_REUSEADDR (restart at once after TIME_WAIT), never SO_REUSEPORT: a busy port must make bind fail.
    if (acceptor.open(endpoint.protocol(), bec) || acceptor.set_option(net::socket_base::reuse_address(true), bec) ||
        acceptor.bind(endpoint, bec) || acceptor.listen(net::socket_base::max_listen_connections, bec)) {
        *status = Status::Io(fmt::format("cannot listen on {}: {}", where, whyBindFails(bec)));
        return nullptr;
    }
    impl->port = acceptor.local_endpoint(bec).port();
    impl->accept();

    // Writes to a client that hung up return EPIPE instead of killing the
    // process: SIGPIPE is blocked in the serving threads.
    const unsigned threads = std::clamp(std::thread::hardware_concurrency(), 2u, 8u);
    Impl* raw = impl.get();
    raw->threads_running = static_cast<int>(threads);
    for (unsigned i = 0; i < threads; ++i) {
        raw->threads.emplace_back([raw] {
            sigset_t pipe;
            sigemptyset(&pipe);
            sigaddset(&pipe, SIGPIPE);
            pthread_sigmask(SIG_BLOCK, &pipe, nullptr);
            raw->io.run();
            --raw->threads_running;
        });
    }
    return std::unique_ptr<StaticServer>(new StaticServer(std::move(impl)));
}

}  // namespace cityatlas::cli
