// SPDX-License-Identifier: GPL-3.0-or-later
#include "ingest/texture_resolver.h"

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>

namespace cityatlas {
namespace fs = std::filesystem;
namespace {

bool isRemote(const std::string& uri) { return uri.find("://") != std::string::npos; }

// Plain names only: no ".", "..", or empty part; `absolute` lets it start
// with one "/".
bool plainPath(std::string_view p, bool absolute) {
    if (absolute && !p.empty() && p.front() == '/') p.remove_prefix(1);
    if (p.empty() || p.front() == '/' || p.back() == '/') return false;
    for (size_t start = 0; start <= p.size();) {
        size_t end = p.find('/', start);
        if (end == std::string_view::npos) end = p.size();
        const std::string_view part = p.substr(start, end - start);
        if (part.empty() || part == "." || part == "..") return false;
        start = end + 1;
    }
    return true;
}

fs::path localPath(const fs::path& base_dir, const std::string& uri) {
    // lexically_normal() costs microseconds; a plain relative URI (the usual
    // "folder/image.png") joined to a plain folder is its result already.
    if (plainPath(base_dir.native(), true) && plainPath(uri, false)) return fs::path(base_dir.native() + '/' + uri);
    return (base_dir / fs::path(uri)).lexically_normal();
}

ImageHeader readHeader(const fs::path& path) {
    ImageHeader h;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) return h;  // Missing
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) {
        OIIO::geterror();  // clear this thread's OIIO error state
        h.kind = ImageHeader::Kind::Unreadable;
        return h;
    }
    const OIIO::ImageSpec& spec = in->spec();
    h.kind = ImageHeader::Kind::Ok;
    h.width_px = spec.width;
    h.height_px = spec.height;
    h.channels = spec.nchannels;
    in->close();
    return h;
}

}  // namespace

// One worker reads headers in the order they were asked for; resolve() takes
// a finished one, waits for the one being read, or reads a still-queued one
// itself (so it never waits behind the queue).
struct TextureResolver::Prefetcher {
    enum class State { Queued, Reading, Done, Claimed };
    struct Entry {
        State state = State::Queued;
        ImageHeader header;
    };
    std::mutex mutex;
    std::condition_variable done;
    std::condition_variable work;
    std::deque<std::string> queue;
    std::unordered_map<std::string, Entry> entries;
    bool stop = false;
    std::thread worker;

    Prefetcher() : worker([this] { run(); }) {}
    ~Prefetcher() {
        {
            std::lock_guard lock(mutex);
            stop = true;
        }
        work.notify_all();
        worker.join();
    }

    void add(const std::string& path) {
        {
            std::lock_guard lock(mutex);
            if (entries.size() >= kMaxPrefetched || !entries.try_emplace(path).second) return;
            queue.push_back(path);
        }
        work.notify_one();
    }

    // The header of `path`, from the worker when it was asked for.
    ImageHeader take(const std::string& path) {
        std::unique_lock lock(mutex);
        auto it = entries.find(path);
        if (it == entries.end()) {
            lock.unlock();
            return readHeader(path);
        }
        if (it->second.state == State::Queued) {
            it->second.state = State::Claimed;  // the worker skips it
            lock.unlock();
            const ImageHeader h = readHeader(path);
            lock.lock();
            entries.erase(path);
            return h;
        }
        done.wait(lock, [&] { return it->second.state == State::Done; });
        const ImageHeader h = it->second.header;
        entries.erase(it);
        return h;
    }

    void run() {
        std::unique_lock lock(mutex);
        for (;;) {
            work.wait(lock, [&] { return stop || !queue.empty(); });
            if (stop) return;
            const std::string path = std::move(queue.front());
            queue.pop_front();
            auto it = entries.find(path);
            if (it == entries.end() || it->second.state != State::Queued) continue;
            it->second.state = State::Reading;
            lock.unlock();
            const ImageHeader h = readHeader(path);
            lock.lock();
            it = entries.find(path);  // rehashing may have moved it
            it->second.header = h;
            it->second.state = State::Done;
            done.notify_all();
        }
    }
};

TextureResolver::TextureResolver(SceneSink& sink, Diagnostics& diagnostics) : sink_(sink), diagnostics_(diagnostics) {}

uint32_t TextureResolver::hashOf(const Key& k) {
    const size_t h = std::hash<std::string_view>{}(k.path) ^ (static_cast<size_t>(k.wrap) * 0x9E3779B97F4A7C15ULL);
    return static_cast<uint32_t>(h ^ (h >> 32));
}

int32_t TextureResolver::findResolved(const Key& k, uint32_t hash) const {
    if (resolved_.empty()) return -1;
    const TextureTable& t = sink_.textures();
    const size_t mask = resolved_.size() - 1;
    for (size_t i = hash & mask;; i = (i + 1) & mask) {
        const uint64_t slot = resolved_[i];
        if (slot == 0) return -1;
        if (static_cast<uint32_t>(slot >> 32) != hash) continue;
        const auto index = static_cast<int32_t>(static_cast<uint32_t>(slot) - 1);
        const auto at = static_cast<size_t>(index);
        if (t[at].wrap == k.wrap && t.path(at) == k.path) return index;  // a path read only when the hashes agree
    }
}

void TextureResolver::addResolved(int32_t index, uint32_t hash) {
    const auto place = [](std::vector<uint64_t>& slots, uint64_t slot) {
        const size_t mask = slots.size() - 1;
        size_t i = static_cast<uint32_t>(slot >> 32) & mask;
        while (slots[i] != 0) i = (i + 1) & mask;
        slots[i] = slot;
    };
    if ((resolved_count_ + 1) * 10 > resolved_.size() * 7) {
        std::vector<uint64_t> grown(std::max<size_t>(64, 2 * resolved_.size()), 0);
        for (const uint64_t slot : resolved_)
            if (slot != 0) place(grown, slot);
        resolved_.swap(grown);
    }
    place(resolved_, uint64_t{hash} << 32 | (static_cast<uint32_t>(index) + 1));
    ++resolved_count_;
}

TextureResolver::~TextureResolver() = default;

void TextureResolver::prefetch(const fs::path& base_dir, const std::string& uri) {
    if (isRemote(uri)) return;
    if (!prefetcher_) prefetcher_ = std::make_unique<Prefetcher>();
    prefetcher_->add(localPath(base_dir, uri).string());
}

int32_t TextureResolver::resolve(const fs::path& base_dir, const std::string& uri, WrapMode wrap,
                                 const DiagnosticExample& where) {
    const bool remote = isRemote(uri);
    const fs::path path = remote ? fs::path() : localPath(base_dir, uri);
    const std::string& where_from = remote ? uri : path.native();
    const Key key{where_from, wrap};
    const uint32_t hash = hashOf(key);
    if (const int32_t found = findResolved(key, hash); found >= 0) return found;
    const std::string failed_key = where_from + "#" + std::to_string(static_cast<int>(wrap));
    if (auto it = failed_keys_.find(failed_key); it != failed_keys_.end()) return it->second;

    int32_t index = -1;
    auto fail = [&](const char* code, std::string detail) {
        DiagnosticExample ex = where;
        ex.detail = std::move(detail);
        diagnostics_.warn(code, std::move(ex));
    };
    if (remote) {
        fail(warn::kTextureMissing, fmt::format("{}: remote images are not fetched", uri));
    } else {
        const ImageHeader h = prefetcher_ ? prefetcher_->take(path.string()) : readHeader(path);
        if (h.kind == ImageHeader::Kind::Missing) {
            fail(warn::kTextureMissing, fmt::format("{}: no such file", path.string()));
        } else if (h.kind == ImageHeader::Kind::Unreadable) {
            fail(warn::kTextureUnreadable, fmt::format("{}: not a readable image", path.string()));
        } else {
            TextureRef ref;
            ref.path = path.string();
            ref.width_px = h.width_px;
            ref.height_px = h.height_px;
            ref.channels = h.channels;
            ref.wrap = wrap;
            index = sink_.addTexture(ref);
        }
    }
    (index >= 0 ? ok_ : failed_)++;
    if (index >= 0) addResolved(index, hash);
    else failed_keys_.emplace(failed_key, index);
    return index;
}

}  // namespace cityatlas
