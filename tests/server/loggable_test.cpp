// loggable() held to its header: every byte that is not printable ASCII, and the backslash,
// comes out as a \xNN escape, so that text from a client cannot end or forge a log line, carry
// a NUL or a terminal escape, or put invalid UTF-8 into the log; the escaping can be undone
// unambiguously; the bound keeps the shortest run of whole escapes that reaches `max`, never
// half of one (nor of a multi-byte character), and "..." marks text left out.
#include "server/loggable.h"

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <random>
#include <string>
#include <string_view>
#include <vector>

namespace tessera::server {
namespace {

bool kept_as_is(unsigned char c) { return c >= 0x20 && c < 0x7f && c != '\\'; }

// The header's escape for one byte, written out independently of the implementation.
std::string escaped(unsigned char c) {
    if (kept_as_is(c)) return std::string(1, char(c));
    static const char kHex[] = "0123456789abcdef";
    return std::string{'\\', 'x', kHex[c >> 4], kHex[c & 15]};
}

std::string escaped_all(std::string_view s) {
    std::string out;
    for (char c : s) out += escaped(static_cast<unsigned char>(c));
    return out;
}

// A log line's text must be printable ASCII throughout: no line break, NUL, escape sequence
// or byte that could be read as (invalid) UTF-8.
bool printable_ascii(std::string_view s) {
    for (char c : s)
        if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) return false;
    return true;
}

// Undoes the escaping; false when the text holds a backslash that starts no whole escape.
bool unescape(std::string_view s, std::string& out) {
    out.clear();
    auto hex = [](char c) -> int {
        if (c >= '0' && c <= '9') return c - '0';
        if (c >= 'a' && c <= 'f') return c - 'a' + 10;
        return -1;
    };
    for (size_t i = 0; i < s.size(); ++i) {
        if (s[i] != '\\') {
            out += s[i];
            continue;
        }
        if (i + 3 >= s.size() || s[i + 1] != 'x' || hex(s[i + 2]) < 0 || hex(s[i + 3]) < 0) return false;
        out += char(hex(s[i + 2]) * 16 + hex(s[i + 3]));
        i += 3;
    }
    return true;
}

// Inputs weighted towards the bytes that matter: line breaks, NUL, ESC, backslash, DEL and
// the pieces of multi-byte characters, among plain text.
std::string random_input(std::mt19937& rng) {
    static const unsigned char kHostile[] = {0x00, '\n', '\r', 0x1b, '\\', 0x7f, 0x80, 0xc3, 0xa9, 0xe2, 0x80, 0xa8, 0xff, 0x09};
    std::uniform_int_distribution<int> length(0, 40), coin(0, 1), printable(0x20, 0x7e),
        hostile(0, int(sizeof kHostile) - 1);
    std::string s(size_t(length(rng)), '\0');
    for (char& c : s) c = char(coin(rng) ? printable(rng) : kHostile[hostile(rng)]);
    return s;
}

TEST(Loggable, EveryByteIsItselfOrItsEscape) {
    for (int b = 0; b < 256; ++b) {
        const unsigned char c = static_cast<unsigned char>(b);
        SCOPED_TRACE(b);
        EXPECT_EQ(loggable(std::string(1, char(c)), 100), escaped(c));
    }
    // The edges of the printable range, spelled out.
    EXPECT_EQ(loggable("\x1f \x7e\x7f", 100), "\\x1f ~\\x7f");
}

TEST(Loggable, TextAfterANulIsKept) {
    // A string_view's length, not a C string's, decides where the text ends.
    EXPECT_EQ(loggable(std::string_view("GET\0/admin", 10), 100), "GET\\x00/admin");
}

TEST(Loggable, NoByteCanBreakOrForgeALogLine) {
    const std::string forged = "/v1/jobs HTTP/1.1\r\n2024-01-01 [info] GET /admin 200\n";
    const std::string r = loggable(forged, 1000);
    EXPECT_EQ(r.find_first_of("\r\n"), std::string::npos) << r;
    EXPECT_TRUE(printable_ascii(r)) << r;
    // Line breaks of other kinds (VT, FF, NEL, U+2028, U+2029) and an ANSI sequence that
    // would move the terminal's cursor up a line and clear it.
    for (std::string_view s : {"\v", "\f", "\xc2\x85", "\xe2\x80\xa8", "\xe2\x80\xa9", "\x1b[1A\x1b[2K", "\x9b" "1A"}) {
        const std::string e = loggable(s, 100);
        EXPECT_TRUE(printable_ascii(e)) << e;
        EXPECT_EQ(e, escaped_all(s));
    }
}

TEST(Loggable, Utf8ValidOrNotComesOutAsAsciiEscapes) {
    // Valid characters are escaped too: the log line stays ASCII whatever the client sent.
    EXPECT_EQ(loggable("caf\xc3\xa9", 100), "caf\\xc3\\xa9");
    EXPECT_EQ(loggable("\xf0\x9f\x98\x80", 100), "\\xf0\\x9f\\x98\\x80");
    // A lone lead byte, a lone continuation byte, an overlong '/', a UTF-16 surrogate, a byte
    // that never occurs in UTF-8.
    for (std::string_view s : {"\xc3", "\xa9", "\xc0\xaf", "\xed\xa0\x80", "\xfe"}) {
        const std::string e = loggable(s, 100);
        EXPECT_TRUE(printable_ascii(e)) << e;
        EXPECT_EQ(e, escaped_all(s));
    }
}

TEST(Loggable, ABackslashCannotPassForAnEscape) {
    // The text "\x0a" typed by a client must not read like an escaped newline.
    EXPECT_EQ(loggable("\\x0a", 100), "\\x5cx0a");
    EXPECT_NE(loggable("\\x0a", 100), loggable("\n", 100));
    std::mt19937 rng(20240601);
    for (int i = 0; i < 2000; ++i) {
        const std::string s = random_input(rng);
        const std::string e = loggable(s, 1000);
        std::string back;
        ASSERT_TRUE(unescape(e, back)) << e;
        ASSERT_EQ(back, s) << e;
    }
}

TEST(Loggable, ACutKeepsEscapesAndCharactersWhole) {
    // "é" is two bytes; a bound that falls inside its escapes keeps whole escapes only, and the
    // result is still ASCII (no lone lead byte, no dangling "\x" or "\xc").
    const std::string s = "ab\xc3\xa9" "cd";
    EXPECT_EQ(loggable(s, 3), "ab\\xc3...");
    EXPECT_EQ(loggable(s, 7), "ab\\xc3\\xa9...");
    EXPECT_EQ(loggable(std::string(10, '\n'), 5), "\\x0a\\x0a...");
    EXPECT_EQ(loggable(std::string(600, 'x'), 512), std::string(512, 'x') + "...");
    EXPECT_EQ(loggable("anything", 0), "...");
}

TEST(Loggable, TheBoundKeepsTheShortestWholePrefixThatReachesIt) {
    // For any input and bound: text that fits is whole; text that is cut keeps exactly the
    // escapes of its first bytes up to the first that reaches `max` (so at most three
    // characters past it, never part of an escape), then "...".
    std::mt19937 rng(7);
    for (int i = 0; i < 5000; ++i) {
        const std::string s = random_input(rng);
        const size_t max = size_t(std::uniform_int_distribution<int>(0, 48)(rng));
        const std::string r = loggable(s, max);
        SCOPED_TRACE(::testing::Message() << "input " << escaped_all(s) << ", max " << max << ", got " << r);
        ASSERT_TRUE(printable_ascii(r));

        std::string body;  // the escapes of the bytes a correct bound keeps
        size_t kept = 0;
        while (kept < s.size() && body.size() < max) body += escaped(static_cast<unsigned char>(s[kept++]));
        if (kept == s.size()) {
            // Nothing was left out; whether "..." follows is EllipsisOnlyWhenTextIsLeftOut's.
            ASSERT_TRUE(r == body || r == body + "...");
            continue;
        }
        ASSERT_EQ(r, body + "...");
        ASSERT_GE(body.size(), max);
        ASSERT_LT(body.size(), max + 4);
    }
}

TEST(Loggable, EllipsisOnlyWhenTextIsLeftOut) {
    // "..." tells whoever reads the log that the text went on; text that fits the bound
    // exactly (or an empty one) is whole and must not look cut.
    EXPECT_EQ(loggable("abc", 3), "abc");
    EXPECT_EQ(loggable("", 0), "");
    EXPECT_EQ(loggable("ab\n", 6), "ab\\x0a");
    EXPECT_EQ(loggable(std::string(512, 'x'), 512), std::string(512, 'x'));
    // One byte more than fits is cut, and says so.
    EXPECT_EQ(loggable("abcd", 3), "abc...");
}

TEST(Loggable, ALargeBoundKeepsEverything) {
    std::mt19937 rng(99);
    for (int i = 0; i < 200; ++i) {
        const std::string s = random_input(rng);
        EXPECT_EQ(loggable(s, SIZE_MAX), escaped_all(s));
    }
}

}  // namespace
}  // namespace tessera::server
