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

// Writes all of `bytes` to a new file and fsyncs it: a rename after a crash must never expose a
// file the disk has not got.
bool write_synced(const std::string& path, const std::string& bytes) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return false;
    size_t at = 0;
    while (at < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + at, bytes.size() - at);
        if (n <= 0) {
            ::close(fd);
            return false;
        }
        at += size_t(n);
    }
    const bool synced = ::fsync(fd) == 0;
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
        if (!write_synced(part, encode_checkpoint(c))) {
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
