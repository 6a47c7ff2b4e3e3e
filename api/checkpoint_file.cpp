#include "api/checkpoint_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace tessera::api {

namespace {

// Streams the checkpoint into a new file and fsyncs it: a rename after a crash must never expose
// a file the disk has not got. Small pieces gather in a buffer; the film's arrays (megabytes) go
// straight from the checkpoint's film, so no copy of its bytes is made (a 4096×4096 denoising
// render's film is 3 GB, and encoded into a string first a checkpoint held it three times over
// beside the render's own).
bool write_synced(const std::string& path, const RenderCheckpoint& c) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return false;
    bool ok = true;
    auto write_all = [&](const char* p, size_t n) {
        while (ok && n > 0) {
            const ssize_t k = ::write(fd, p, n);
            if (k <= 0) {
                ok = false;
                break;
            }
            p += k;
            n -= size_t(k);
        }
    };
    constexpr size_t kBuffer = size_t(1) << 16;
    std::string buffer;
    buffer.reserve(kBuffer);
    encode_checkpoint(c, [&](const char* p, size_t n) {
        if (!ok) return;  // the disk refused: the rest is not buffered for nothing
        if (buffer.size() + n > kBuffer) {
            write_all(buffer.data(), buffer.size());
            buffer.clear();
        }
        if (n >= kBuffer) write_all(p, n);
        else buffer.append(p, n);
    });
    write_all(buffer.data(), buffer.size());
    const bool synced = ok && ::fsync(fd) == 0;
    return ::close(fd) == 0 && synced;
}

void sync_directory(const std::filesystem::path& dir) {
    const int fd = ::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    ::fsync(fd);
    ::close(fd);
}

}  // namespace

bool write_checkpoint(const std::string& path, const RenderCheckpoint& c) noexcept {
    try {
        // A shot's frame has no folder of its own until it is written.
        std::error_code ec;
        std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
        const std::string part = path + ".part";
        if (!write_synced(part, c)) {
            std::remove(part.c_str());
            return false;
        }
        if (std::rename(part.c_str(), path.c_str()) != 0) {
            std::remove(part.c_str());
            return false;
        }
        sync_directory(std::filesystem::path(path).parent_path());
        return true;
    } catch (...) {  // out of memory encoding it: the render goes on without this checkpoint
        return false;
    }
}

std::optional<RenderCheckpoint> read_checkpoint(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return std::nullopt;
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    try {
        return decode_checkpoint(bytes);
    } catch (const std::runtime_error&) {
        std::filesystem::remove(path);
        return std::nullopt;
    }
}

}  // namespace tessera::api
