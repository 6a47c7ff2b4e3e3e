// MurmurHash3_x86_32 gives its published values (Cryptomatte's ids depend on every bit), tails of
// one to three bytes included, and bytes above 127 read unsigned.
#include "engine/core/murmur3.h"

#include <gtest/gtest.h>

namespace tessera {
namespace {

TEST(Murmur3, PublishedValues) {
    static_assert(murmur3_32("") == 0u);
    EXPECT_EQ(murmur3_32("", 1), 0x514e28b7u);
    EXPECT_EQ(murmur3_32("", 0xffffffffu), 0x81f16f39u);
    EXPECT_EQ(murmur3_32(std::string_view("\0\0\0\0", 4)), 0x2362f9deu);
    EXPECT_EQ(murmur3_32("a"), 0x3c2569b2u);
    EXPECT_EQ(murmur3_32("ab"), 0x9bbfd75fu);
    EXPECT_EQ(murmur3_32("abc"), 0xb3dd93fau);
    EXPECT_EQ(murmur3_32("abcd"), 0x43ed676au);
    EXPECT_EQ(murmur3_32("hello"), 0x248bfa47u);
    EXPECT_EQ(murmur3_32("The quick brown fox jumps over the lazy dog"), 0x2e4ff723u);
    EXPECT_EQ(murmur3_32(std::string_view("\xff\xff\xff\xff", 4)), 0x76293b50u);
}

}  // namespace
}  // namespace tessera
