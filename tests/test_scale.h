#pragma once
// Sanitizer builds run the heavy statistical loops with fewer samples; the tolerances come
// from the measured variance, so they stay honest either way.
namespace tessera::test {
#if defined(__SANITIZE_ADDRESS__)
inline constexpr int kWorkScale = 10;
#else
inline constexpr int kWorkScale = 1;
#endif
}  // namespace tessera::test
