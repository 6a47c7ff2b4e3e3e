#include "api/preview_video.h"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace tessera::api {
namespace {

namespace fs = std::filesystem;

std::string read_tail(const fs::path& p, size_t max) {
    std::ifstream in(p, std::ios::binary);
    std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (s.size() > max) s = "..." + s.substr(s.size() - max);
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    return s;
}

}  // namespace

std::string find_ffmpeg() {
    if (const char* e = std::getenv("TESSERA_FFMPEG"); e && *e) return fs::exists(e) ? e : "";
    const char* path = std::getenv("PATH");
    std::string dirs = path ? path : "/usr/bin:/bin";
    size_t at = 0;
    while (at <= dirs.size()) {
        const size_t colon = std::min(dirs.find(':', at), dirs.size());
        const fs::path candidate = fs::path(dirs.substr(at, colon - at)) / "ffmpeg";
        if (!candidate.parent_path().empty() && ::access(candidate.c_str(), X_OK) == 0) return candidate.string();
        at = colon + 1;
    }
    return "";
}

PreviewResult write_preview(const std::vector<std::string>& pngs, double fps, const std::string& mp4) {
    const auto t0 = std::chrono::steady_clock::now();
    PreviewResult r;
    const std::string ffmpeg = find_ffmpeg();
    if (ffmpeg.empty()) {
        r.why_not = "ffmpeg is not installed (Debian's ffmpeg package encodes the preview)";
        return r;
    }
    if (pngs.empty()) {
        r.why_not = "no frames";
        return r;
    }
    // ffmpeg reads numbered files: the frames' PNGs linked under sequential names beside the
    // preview, removed afterwards.
    std::error_code ec;
    const fs::path work = fs::path(mp4).parent_path() / ".preview_frames";
    fs::remove_all(work, ec);
    fs::create_directories(work, ec);
    if (ec) {
        r.why_not = "cannot make " + work.string() + ": " + ec.message();
        return r;
    }
    for (size_t i = 0; i < pngs.size(); ++i) {
        char name[32];
        std::snprintf(name, sizeof name, "%08zu.png", i);
        fs::create_symlink(fs::absolute(pngs[i]), work / name, ec);
        if (ec) {
            r.why_not = "cannot link " + pngs[i] + ": " + ec.message();
            fs::remove_all(work, ec);
            return r;
        }
    }
    char rate[32];
    std::snprintf(rate, sizeof rate, "%.6g", fps);
    const fs::path log = work / "ffmpeg.log";
    const std::string pattern = (work / "%08d.png").string(), tmp = mp4 + ".part.mp4";
    // H.264 needs even sizes; yuv420p plays everywhere; +faststart puts the index first.
    std::vector<std::string> args = {ffmpeg, "-nostdin", "-y", "-loglevel", "error", "-framerate", rate, "-i", pattern,
                                     "-vf", "scale=trunc(iw/2)*2:trunc(ih/2)*2", "-c:v", "libx264", "-pix_fmt", "yuv420p",
                                     "-movflags", "+faststart", tmp};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    pid_t pid = 0;
    const int spawned = posix_spawn(&pid, ffmpeg.c_str(), &actions, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    int status = 0;
    if (spawned != 0) {
        r.why_not = "cannot start " + ffmpeg;
    } else {
        while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
        }
        if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
            fs::rename(tmp, mp4, ec);
            if (ec) r.why_not = "cannot move the preview into place: " + ec.message();
            else r.written = true;
        } else {
            r.why_not = "ffmpeg failed: " + read_tail(log, 400);
        }
    }
    fs::remove(tmp, ec);
    fs::remove_all(work, ec);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

}  // namespace tessera::api
