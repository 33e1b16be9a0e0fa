// SPDX-License-Identifier: GPL-3.0-or-later
#include "render/loader/loader.h"

#include "render/loader/byte_cache.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <string_view>
#include <thread>
#include <unordered_set>

#include <curl/curl.h>
#include <fmt/format.h>

#include "render/loader/block_decoder.h"
#include "render/loader/byte_cache.h"

namespace cityatlas::render {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

void globalCurlInit() {
    static std::once_flag once;
    std::call_once(once, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
}

// The folder or URL prefix that uris are joined to.
std::string baseOf(const std::string& source) {
    constexpr std::string_view name = "tileset.json";
    std::string_view s = source;
    if (s.size() >= name.size() && s.substr(s.size() - name.size()) == name) s.remove_suffix(name.size());
    if (s.empty()) return "./";
    return s.back() == '/' ? std::string(s) : fmt::format("{}/", s);
}

size_t appendBody(char* data, size_t size, size_t count, void* user) {
    auto* body = static_cast<std::vector<uint8_t>*>(user);
    body->insert(body->end(), reinterpret_cast<uint8_t*>(data), reinterpret_cast<uint8_t*>(data) + size * count);
    return size * count;
}

bool readFile(const std::string& path, std::vector<uint8_t>* out, std::string* why) {
    std::ifstream f(path, std::ios::binary);
    if (!f) {
        std::error_code ec;
        *why = fs::exists(path, ec) ? "cannot open" : "missing";
        return false;
    }
    out->assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    if (f.bad()) {
        *why = "read error";
        return false;
    }
    return true;
}

}  // namespace

const char* loadErrorName(LoadError e) {
    switch (e) {
        case LoadError::None: return "none";
        case LoadError::NotFound: return "not_found";
        case LoadError::Http: return "http";
        case LoadError::Network: return "network";
        case LoadError::Timeout: return "timeout";
        case LoadError::Truncated: return "truncated";
        case LoadError::Corrupt: return "corrupt";
    }
    return "?";
}

bool isUrl(const std::string& s) { return s.rfind("http://", 0) == 0 || s.rfind("https://", 0) == 0; }

Status fetchTilesetText(const std::string& source, std::string* text) { return fetchText(source, "tileset.json", text); }

Status fetchText(const std::string& source, const std::string& uri, std::string* text) {
    const std::string where = baseOf(source) + uri;
    if (!isUrl(source)) {
        std::error_code ec;
        const std::string folder = baseOf(source);
        if (!fs::is_directory(folder, ec)) return Status::Io(fmt::format("{}: no such folder", source));
        std::vector<uint8_t> bytes;
        std::string why;
        if (!readFile(where, &bytes, &why))
            return Status::Io(fmt::format("{}: {}{}", where, why,
                                            why == "missing" && uri == "tileset.json" ? " (not a cityatlas tile folder)" : ""));
        text->assign(bytes.begin(), bytes.end());
        return Status::Ok();
    }
    globalCurlInit();
    CURL* easy = curl_easy_init();
    if (!easy) return Status::Io(where + ": cannot start libcurl");
    std::vector<uint8_t> body;
    char error[CURL_ERROR_SIZE] = {0};
    curl_easy_setopt(easy, CURLOPT_URL, where.c_str());
    curl_easy_setopt(easy, CURLOPT_WRITEFUNCTION, appendBody);
    curl_easy_setopt(easy, CURLOPT_WRITEDATA, &body);
    curl_easy_setopt(easy, CURLOPT_ERRORBUFFER, error);
    curl_easy_setopt(easy, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(easy, CURLOPT_FOLLOWLOCATION, 1L);
    curl_easy_setopt(easy, CURLOPT_CONNECTTIMEOUT, 10L);
    curl_easy_setopt(easy, CURLOPT_TIMEOUT, 60L);
    const CURLcode rc = curl_easy_perform(easy);
    long status = 0;
    curl_easy_getinfo(easy, CURLINFO_RESPONSE_CODE, &status);
    curl_easy_cleanup(easy);
    if (rc != CURLE_OK)
        return Status::Io(fmt::format("{}: cannot fetch: {}", where, error[0] ? error : curl_easy_strerror(rc)));
    if (status == 404 || status == 410)
        return Status::Invalid(fmt::format("{}: HTTP {} (no cityatlas tile folder there)", where, status));
    if (status != 200) return Status::Io(fmt::format("{}: HTTP {}", where, status));
    text->assign(body.begin(), body.end());
    return Status::Ok();
}

struct Loader::Impl {
    const TilesetIndex* index = nullptr;
    LoaderOptions options;
    std::string base;
    bool http = false;

    mutable std::mutex mutex;
    std::condition_variable work_ready, result_ready;
    bool stop = false;

    struct Job {
        BlockId id = kNoBlock;
        std::vector<uint8_t> bytes;  ///< fetched already (HTTP) or from the RAM level; empty: read the file
        bool fetched = false;
        bool from_ram = false;       ///< the bytes came from the RAM level (kept there already)
        int attempts = 1;
        Clock::time_point started;
    };
    std::deque<Job> work;                      ///< for the decode workers
    std::deque<BlockId> to_fetch;              ///< for the network thread
    std::set<BlockId> pending;                 ///< requested, result not polled yet
    std::map<BlockId, Clock::time_point> requested_at;
    std::vector<LoadResult> results;
    LoaderStats stats;
    ByteCache ram;
    std::vector<std::thread> workers;
    std::thread network;
    CURLM* multi = nullptr;

    bool wanted(BlockId id) const { return pending.count(id) > 0; }

    // Under the lock: a finished job becomes a result unless it was cancelled meanwhile.
    void deliver(LoadResult r) {
        if (!wanted(r.id) || std::any_of(results.begin(), results.end(), [&](const LoadResult& x) { return x.id == r.id; })) {
            ++stats.cancelled;
            return;
        }
        if (r.error == LoadError::None) ++stats.completed;
        else {
            ++stats.failed;
            ++stats.errors_by_kind[static_cast<size_t>(r.error)];
        }
        results.push_back(std::move(r));
        result_ready.notify_all();
    }

    void decodeWorker() {
        for (;;) {
            Job job;
            {
                std::unique_lock lock(mutex);
                work_ready.wait(lock, [&] { return stop || !work.empty(); });
                if (stop) return;
                job = std::move(work.front());
                work.pop_front();
                if (!wanted(job.id)) {
                    ++stats.cancelled;
                    continue;
                }
            }
            const BlockInfo& info = index->blocks[job.id];
            LoadResult r;
            r.id = job.id;
            r.attempts = job.attempts;
            std::vector<uint8_t> bytes = std::move(job.bytes);
            if (!job.fetched) {
                std::string why;
                if (!readFile(base + info.uri, &bytes, &why)) {
                    r.error = why == "missing" ? LoadError::NotFound : LoadError::Network;
                    r.message = fmt::format("{}: {}", info.uri, why);
                }
            }
            r.bytes_fetched = bytes.size();
            if (r.error == LoadError::None) {
                if (bytes.size() < info.bytes) {
                    r.error = LoadError::Truncated;
                    r.message = fmt::format("{}: {} bytes, tileset.json says {}", info.uri, bytes.size(), info.bytes);
                } else if (Status st = decodeBlock(*index, job.id, bytes, &r.block); !st.ok()) {
                    r.error = LoadError::Corrupt;
                    r.message = st.error;
                }
            }
            r.seconds = std::chrono::duration<double>(Clock::now() - job.started).count();
            std::lock_guard lock(mutex);
            if (!job.fetched) stats.bytes_fetched += r.bytes_fetched;
            if (job.from_ram) r.bytes_fetched = 0;
            // Good bytes stay in RAM for the next request (a GPU eviction keeps them).
            if (r.error == LoadError::None && !job.from_ram && ram.budget() > 0) {
                ram.put(job.id, std::move(bytes));
                stats.ram_bytes = ram.bytes();
            }
            deliver(std::move(r));
        }
    }

    struct Transfer {
        BlockId id = kNoBlock;
        CURL* easy = nullptr;
        std::vector<uint8_t> body;
        int attempt = 1;
        Clock::time_point started;
        char error[CURL_ERROR_SIZE] = {0};
    };

    void networkLoop() {
        std::map<BlockId, std::unique_ptr<Transfer>> active;
        std::multimap<Clock::time_point, std::pair<BlockId, int>> retry_at;  // when, (block, next attempt)
        auto finish = [&](Transfer& t, LoadError error, const std::string& message) {
            LoadResult r;
            r.id = t.id;
            r.error = error;
            r.message = message;
            r.attempts = t.attempt;
            r.bytes_fetched = t.body.size();
            r.seconds = std::chrono::duration<double>(Clock::now() - t.started).count();
            deliver(std::move(r));
        };
        auto start = [&](BlockId id, int attempt, Clock::time_point started) {
            auto t = std::make_unique<Transfer>();
            t->id = id;
            t->attempt = attempt;
            t->started = started;
            t->easy = curl_easy_init();
            const std::string url = base + index->blocks[id].uri;
            curl_easy_setopt(t->easy, CURLOPT_URL, url.c_str());
            curl_easy_setopt(t->easy, CURLOPT_WRITEFUNCTION, appendBody);
            curl_easy_setopt(t->easy, CURLOPT_WRITEDATA, &t->body);
            curl_easy_setopt(t->easy, CURLOPT_ERRORBUFFER, t->error);
            curl_easy_setopt(t->easy, CURLOPT_PRIVATE, t.get());
            curl_easy_setopt(t->easy, CURLOPT_NOSIGNAL, 1L);
            curl_easy_setopt(t->easy, CURLOPT_FOLLOWLOCATION, 1L);
            curl_easy_setopt(t->easy, CURLOPT_TCP_KEEPALIVE, 1L);
            curl_easy_setopt(t->easy, CURLOPT_CONNECTTIMEOUT_MS, static_cast<long>(std::min(10.0, options.timeout_s) * 1000));
            curl_easy_setopt(t->easy, CURLOPT_TIMEOUT_MS, static_cast<long>(options.timeout_s * 1000));
            t->body.reserve(index->blocks[id].bytes);
            curl_multi_add_handle(multi, t->easy);
            active[id] = std::move(t);
        };
        auto drop = [&](std::map<BlockId, std::unique_ptr<Transfer>>::iterator it) {
            curl_multi_remove_handle(multi, it->second->easy);
            curl_easy_cleanup(it->second->easy);
            return active.erase(it);
        };
        for (;;) {
            {
                std::unique_lock lock(mutex);
                if (stop) break;
                // Cancelled transfers are aborted.
                for (auto it = active.begin(); it != active.end();) it = wanted(it->first) ? std::next(it) : drop(it);
                // Due retries first, then new requests, up to the connection limit.
                const auto now = Clock::now();
                while (!retry_at.empty() && retry_at.begin()->first <= now &&
                       active.size() < static_cast<size_t>(options.max_connections)) {
                    const auto [id, attempt] = retry_at.begin()->second;
                    retry_at.erase(retry_at.begin());
                    if (wanted(id) && !active.count(id)) start(id, attempt, requested_at[id]);
                }
                while (!to_fetch.empty() && active.size() < static_cast<size_t>(options.max_connections)) {
                    const BlockId id = to_fetch.front();
                    to_fetch.pop_front();
                    if (wanted(id) && !active.count(id)) start(id, 1, requested_at[id]);
                }
            }
            int running = 0;
            curl_multi_perform(multi, &running);
            int left = 0;
            while (CURLMsg* msg = curl_multi_info_read(multi, &left)) {
                if (msg->msg != CURLMSG_DONE) continue;
                Transfer* t = nullptr;
                curl_easy_getinfo(msg->easy_handle, CURLINFO_PRIVATE, &t);
                const CURLcode code = msg->data.result;
                long status = 0;
                curl_easy_getinfo(msg->easy_handle, CURLINFO_RESPONSE_CODE, &status);
                const BlockInfo& info = index->blocks[t->id];
                const std::string url = base + info.uri;
                LoadError error = LoadError::None;
                std::string message;
                bool retry = false;
                if (code == CURLE_OK && status == 200) {
                    if (t->body.size() != info.bytes) {
                        error = LoadError::Truncated;
                        retry = t->body.size() < info.bytes;
                        message = fmt::format("{}: {} bytes, tileset.json says {}", url, t->body.size(), info.bytes);
                    }
                } else if (code == CURLE_OK) {
                    error = status == 404 || status == 410 ? LoadError::NotFound : LoadError::Http;
                    retry = status >= 500;
                    message = fmt::format("{}: HTTP {}", url, status);
                } else if (code == CURLE_PARTIAL_FILE) {
                    error = LoadError::Truncated;
                    retry = true;
                    message = fmt::format("{}: body shorter than its Content-Length ({})", url, t->error);
                } else {
                    error = code == CURLE_OPERATION_TIMEDOUT ? LoadError::Timeout : LoadError::Network;
                    retry = true;
                    message = fmt::format("{}: {}", url, t->error[0] ? t->error : curl_easy_strerror(code));
                }
                std::unique_lock lock(mutex);
                stats.bytes_fetched += t->body.size();
                const auto it = active.find(t->id);
                if (error == LoadError::None) {
                    Job job;
                    job.id = t->id;
                    job.bytes = std::move(t->body);
                    job.fetched = true;
                    job.attempts = t->attempt;
                    job.started = t->started;
                    work.push_back(std::move(job));
                    work_ready.notify_one();
                } else if (retry && t->attempt <= options.retries && wanted(t->id)) {
                    ++stats.retries;
                    const double wait = options.retry_backoff_s * static_cast<double>(1 << std::min(t->attempt - 1, 10));
                    retry_at.emplace(Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(wait)),
                                     std::make_pair(t->id, t->attempt + 1));
                } else {
                    finish(*t, error, message);
                }
                if (it != active.end()) drop(it);
            }
            // Wait for socket activity, a wakeup (new request, cancel, stop) or the next retry.
            int timeout_ms = 100;
            curl_multi_poll(multi, nullptr, 0, timeout_ms, nullptr);
        }
        for (auto it = active.begin(); it != active.end();) it = drop(it);
    }
};

std::unique_ptr<Loader> Loader::open(const std::string& source, const TilesetIndex& index, const LoaderOptions& options,
                                     Status* status) {
    std::unique_ptr<Loader> l(new Loader());
    l->impl_ = std::make_unique<Impl>();
    Impl& m = *l->impl_;
    m.index = &index;
    m.options = options;
    m.options.decode_threads = std::max(1, options.decode_threads);
    m.options.max_connections = std::max(1, options.max_connections);
    m.base = baseOf(source);
    m.http = isUrl(source);
    m.ram = ByteCache(options.ram_budget_bytes);
    if (m.http) {
        globalCurlInit();
        m.multi = curl_multi_init();
        if (!m.multi) {
            *status = Status::Io(source + ": cannot start libcurl");
            return nullptr;
        }
        curl_multi_setopt(m.multi, CURLMOPT_MAX_HOST_CONNECTIONS, static_cast<long>(m.options.max_connections));
        curl_multi_setopt(m.multi, CURLMOPT_MAX_TOTAL_CONNECTIONS, static_cast<long>(m.options.max_connections));
        m.network = std::thread([&m] { m.networkLoop(); });
    }
    for (int i = 0; i < m.options.decode_threads; ++i) m.workers.emplace_back([&m] { m.decodeWorker(); });
    *status = Status::Ok();
    return l;
}

Loader::~Loader() {
    if (!impl_) return;
    {
        std::lock_guard lock(impl_->mutex);
        impl_->stop = true;
        impl_->pending.clear();
    }
    impl_->work_ready.notify_all();
    if (impl_->multi) curl_multi_wakeup(impl_->multi);
    for (std::thread& t : impl_->workers) t.join();
    if (impl_->network.joinable()) impl_->network.join();
    if (impl_->multi) curl_multi_cleanup(impl_->multi);
}

void Loader::request(BlockId id) {
    Impl& m = *impl_;
    {
        std::lock_guard lock(m.mutex);
        if (id >= m.index->blocks.size() || m.pending.count(id)) return;
        m.pending.insert(id);
        m.requested_at[id] = Clock::now();
        ++m.stats.requests;
        Impl::Job held;
        if (m.ram.get(id, &held.bytes)) {  // the RAM level: decode only
            ++m.stats.ram_hits;
            held.id = id;
            held.fetched = held.from_ram = true;
            held.started = Clock::now();
            m.work.push_back(std::move(held));
            m.work_ready.notify_one();
            return;
        }
        if (m.http) {
            m.to_fetch.push_back(id);
        } else {
            Impl::Job job;
            job.id = id;
            job.started = Clock::now();
            m.work.push_back(std::move(job));
            m.work_ready.notify_one();
        }
    }
    if (m.http) curl_multi_wakeup(m.multi);
}

void Loader::touch(const std::vector<BlockId>& ideal, uint64_t frame) {
    std::lock_guard lock(impl_->mutex);
    impl_->ram.touch(ideal, frame);
}

void Loader::cancel(BlockId id) {
    Impl& m = *impl_;
    {
        std::lock_guard lock(m.mutex);
        if (!m.pending.erase(id)) return;
        m.requested_at.erase(id);
        const auto it = std::remove_if(m.results.begin(), m.results.end(), [&](const LoadResult& r) { return r.id == id; });
        m.stats.cancelled += static_cast<uint64_t>(m.results.end() - it);
        m.results.erase(it, m.results.end());
    }
    if (m.http) curl_multi_wakeup(m.multi);
}

std::vector<LoadResult> Loader::poll() {
    std::lock_guard lock(impl_->mutex);
    std::vector<LoadResult> out;
    out.swap(impl_->results);
    for (const LoadResult& r : out) {
        impl_->pending.erase(r.id);
        impl_->requested_at.erase(r.id);
    }
    return out;
}

bool Loader::waitForAny(double timeout_s) {
    std::unique_lock lock(impl_->mutex);
    return impl_->result_ready.wait_for(lock, std::chrono::duration<double>(timeout_s),
                                        [&] { return !impl_->results.empty() || impl_->stop; });
}

size_t Loader::pending() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->pending.size();
}

LoaderStats Loader::stats() const {
    std::lock_guard lock(impl_->mutex);
    return impl_->stats;
}

}  // namespace cityatlas::render
