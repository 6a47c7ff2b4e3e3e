#pragma once
// A test's own empty folder under the system's temporary directory, named by the process and
// the running test (so parallel test processes never share one), removed afterwards.
#include <filesystem>
#include <string>
#include <system_error>

#include <gtest/gtest.h>
#include <unistd.h>

namespace tessera::test {

inline std::filesystem::path scratch_dir(const std::string& prefix) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::filesystem::path dir = std::filesystem::temp_directory_path() /
        (prefix + "_" + std::to_string(::getpid()) + "_" + (info ? info->name() : "suite"));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

inline void remove_scratch_dir(const std::filesystem::path& dir) {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
}

}  // namespace tessera::test
