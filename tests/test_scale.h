#pragma once
// Sanitizer builds run the heavy statistical loops with fewer samples; the tolerances come
// from the measured variance, so they stay honest either way. GCC says it is sanitizing with
// __SANITIZE_ADDRESS__, clang (CI's sanitizer build) only through __has_feature.
namespace tessera::test {
#if defined(__SANITIZE_ADDRESS__)
#define TESSERA_TEST_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TESSERA_TEST_SANITIZED 1
#endif
#endif
#ifdef TESSERA_TEST_SANITIZED
inline constexpr int kWorkScale = 10;
#else
inline constexpr int kWorkScale = 1;
#endif
}  // namespace tessera::test
