// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// \file
/// Fetches and decodes blocks off the render thread. The source is a folder
/// (files read by the decode workers) or an http(s) URL: then one network
/// thread drives libcurl's multi interface — connections kept alive and
/// reused, at most `max_connections` transfers at once, a timeout per
/// transfer, retries with exponential backoff on 5xx, timeouts, broken
/// connections and short bodies (never on 4xx), cancellation that aborts a
/// transfer in flight. Decoding (Draco, DDS headers) runs on worker threads;
/// the render thread collects finished blocks with poll(). Nothing throws and
/// no input crashes it: every failure is a LoadResult with a one-line message.

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/status.h"
#include "render/core/decoded.h"
#include "render/core/tileset_index.h"

namespace cityatlas::render {

struct LoaderOptions {
    int decode_threads = 2;
    int max_connections = 6;      ///< HTTP transfers at once (and connections per host)
    int retries = 3;              ///< further attempts after a retryable failure
    double retry_backoff_s = 0.25;  ///< first wait; doubles per attempt
    double timeout_s = 30;        ///< per transfer (and 10 s to connect)
    /// The RAM level (byte_cache.h): block bytes kept after a load, so a
    /// request for a block held there is decoded without I/O. 0: off.
    uint64_t ram_budget_bytes = 0;
};

enum class LoadError : uint8_t { None, NotFound, Http, Network, Timeout, Truncated, Corrupt };
inline constexpr size_t kLoadErrorKinds = 7;
const char* loadErrorName(LoadError error);  ///< "none", "not_found", "http", "network", "timeout", "truncated", "corrupt"

struct LoadResult {
    BlockId id = kNoBlock;
    LoadError error = LoadError::None;
    std::string message;          ///< one line: uri (or URL) and what went wrong
    DecodedBlock block;           ///< valid when error == None
    uint64_t bytes_fetched = 0;
    int attempts = 1;
    double seconds = 0;           ///< from request() to finished
};

struct LoaderStats {
    uint64_t requests = 0, completed = 0, failed = 0, cancelled = 0, retries = 0, bytes_fetched = 0;
    uint64_t ram_hits = 0;   ///< requests served from the RAM level (no file read, no transfer)
    uint64_t ram_bytes = 0;  ///< bytes the RAM level holds now (<= LoaderOptions::ram_budget_bytes)
    std::array<uint64_t, kLoadErrorKinds> errors_by_kind{};
};

/// True for http:// and https:// sources.
bool isUrl(const std::string& source);

/// Reads SOURCE/tileset.json (SOURCE a folder or URL; a trailing
/// "tileset.json" is accepted). One line on failure, e.g.
/// "http://127.0.0.1:9/tileset.json: cannot fetch: Failed to connect ... Connection refused".
Status fetchTilesetText(const std::string& source, std::string* text);

/// Reads SOURCE/uri (a feature table, ...) the same way, synchronously.
Status fetchText(const std::string& source, const std::string& uri, std::string* text);

class Loader {
public:
    /// `index` must outlive the loader.
    static std::unique_ptr<Loader> open(const std::string& source, const TilesetIndex& index, const LoaderOptions& options,
                                        Status* status);
    ~Loader();  ///< cancels everything and joins the threads (promptly, even with hung transfers)
    Loader(const Loader&) = delete;
    Loader& operator=(const Loader&) = delete;

    void request(BlockId id);          ///< idempotent while pending; served first come first served (RAM level first)
    /// This frame's ideal set: the RAM level stamps the blocks it holds with
    /// `frame` (increasing), which orders its evictions.
    void touch(const std::vector<BlockId>& ideal, uint64_t frame);
    void cancel(BlockId id);           ///< dropped if queued, aborted if in flight; no result is delivered
    std::vector<LoadResult> poll();    ///< finished results (non-blocking)
    bool waitForAny(double timeout_s); ///< until a result is ready (true) or the timeout passes
    size_t pending() const;            ///< requested and not yet polled
    LoaderStats stats() const;

private:
    Loader() = default;
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace cityatlas::render
