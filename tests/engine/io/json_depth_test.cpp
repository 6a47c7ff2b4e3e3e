// json_nesting_depth: the exact depth up to the caller's bound, exactly one past it and no further
// (a flood of brackets costs nothing), brackets inside strings and escapes read as JSON reads them,
// stray closers unable to hide a deep text; and the glTF loader refusing one level past
// LoadLimits::max_json_depth while taking a file exactly at it.
#include "engine/io/json_depth.h"

#include <string>

#include <gtest/gtest.h>

#include "engine/io/gltf_loader.h"

namespace tessera {
namespace {

std::string nested(int depth, const std::string& inside = "0") {
    return std::string(size_t(depth), '[') + inside + std::string(size_t(depth), ']');
}

TEST(JsonDepth, CountsArraysAndObjectsAlike) {
    EXPECT_EQ(json_nesting_depth("", 10), 0);
    EXPECT_EQ(json_nesting_depth("42", 10), 0);
    EXPECT_EQ(json_nesting_depth("\"text\"", 10), 0);
    EXPECT_EQ(json_nesting_depth("[]", 10), 1);
    EXPECT_EQ(json_nesting_depth("{}", 10), 1);
    EXPECT_EQ(json_nesting_depth("[{}]", 10), 2);
    EXPECT_EQ(json_nesting_depth(R"({"a":[1,{"b":[]}],"c":{}})", 10), 4);
}

// Depth is the deepest point, not a running total of every bracket seen.
TEST(JsonDepth, SiblingsDoNotAddUp) {
    EXPECT_EQ(json_nesting_depth("[[],[],[],[]]", 10), 2);
    EXPECT_EQ(json_nesting_depth(R"([{"a":[]},{"b":[]},{"c":[]}])", 10), 3);
    EXPECT_EQ(json_nesting_depth("[] [] []", 10), 1);
    EXPECT_EQ(json_nesting_depth("[[[1]]] [1]", 10), 3);
}

// Callers refuse when the answer is above their bound, so a text exactly at the bound must
// report the bound itself and one level more must report more.
TEST(JsonDepth, TheBoundIsInclusive) {
    for (int bound : {0, 1, 2, 7, 64}) {
        EXPECT_EQ(json_nesting_depth(nested(bound), bound), bound) << "bound " << bound;
        EXPECT_EQ(json_nesting_depth(nested(bound + 1), bound), bound + 1) << "bound " << bound;
    }
    EXPECT_EQ(json_nesting_depth(R"({"a":{"b":[1]}})", 3), 3);
    EXPECT_EQ(json_nesting_depth(R"({"a":{"b":[{}]}})", 3), 4);
}

// A hostile flood stops being counted one level past the bound: the answer says "too deep",
// not how deep, so a 100,000-bracket text is not walked to its end for nothing.
TEST(JsonDepth, StopsOneLevelPastTheBound) {
    const std::string flood(100000, '[');
    EXPECT_EQ(json_nesting_depth(flood, 64), 65);
    EXPECT_EQ(json_nesting_depth(flood, 0), 1);
    EXPECT_EQ(json_nesting_depth(nested(500), 3), 4);
    // Below the bound the count is exact, closed or not.
    EXPECT_EQ(json_nesting_depth(std::string(30, '{'), 64), 30);
}

TEST(JsonDepth, BracketsInsideStringsAreText) {
    EXPECT_EQ(json_nesting_depth(R"("[[[[[[[[")", 0), 0);
    EXPECT_EQ(json_nesting_depth(R"(["{{{{", "[[[["])", 10), 1);
    EXPECT_EQ(json_nesting_depth(R"({"[[[": "{{{", "k": ["]]]"]})", 10), 2);
    // Closing brackets in a string do not lower the depth either.
    EXPECT_EQ(json_nesting_depth(R"(["]]]]]", [["x"]]])", 10), 3);
    EXPECT_EQ(json_nesting_depth(R"({"}}}}": {"a": {"b": 1}}})", 10), 3);
}

TEST(JsonDepth, EscapesAreReadAsJsonReadsThem) {
    // \" keeps the string open: the brackets after it are text.
    EXPECT_EQ(json_nesting_depth(R"(["a\"[[[[", 1])", 10), 1);
    // \\ is one backslash: the quote after it closes the string and the brackets count.
    EXPECT_EQ(json_nesting_depth(R"(["\\", [[[1]]]])", 10), 4);
    // \\\" is a backslash and a quote, both inside the string.
    EXPECT_EQ(json_nesting_depth(R"(["\\\"[[[", 1])", 10), 1);
    // Other escapes (\n, \u005b which is '[') end at their own character.
    EXPECT_EQ(json_nesting_depth(R"(["\n", ["\u005b"]])", 10), 2);
    // An escaped quote just before the real end of the string.
    EXPECT_EQ(json_nesting_depth(R"([["\""], [[2]]])", 10), 3);
}

TEST(JsonDepth, MultibyteUtf8InStringsIsJustText) {
    EXPECT_EQ(json_nesting_depth("[\"\xE2\x80\x9C[[\xE2\x80\x9D\", \"\xC3\xA9]]\"]", 10), 1);
}

// Closers before any opener must not drive the count below zero, or a text could open with
// "]]]]]]" and then nest that much deeper than the bound unnoticed.
TEST(JsonDepth, StrayClosersCannotHideDepth) {
    EXPECT_EQ(json_nesting_depth("]]]]][[", 10), 2);
    EXPECT_EQ(json_nesting_depth("}}}}}}" + nested(5), 10), 5);
    EXPECT_EQ(json_nesting_depth(std::string(1000, ']') + nested(4), 3), 4);
    EXPECT_EQ(json_nesting_depth("[]]]][[[", 10), 3);
}

// Malformed text is the parser's to judge; the count stays what the brackets say.
TEST(JsonDepth, MalformedTextIsCountedNotJudged) {
    EXPECT_EQ(json_nesting_depth("[{]}", 10), 2);
    EXPECT_EQ(json_nesting_depth("[[[ not JSON", 10), 3);
    // An unterminated string swallows the rest.
    EXPECT_EQ(json_nesting_depth(R"(["abc [[[[[[)", 10), 1);
}

// --- the bound as the glTF loader applies it ------------------------------------------------

// A glTF nesting `depth` deep: the top-level object is 1, "extras" adds the rest.
std::string gltf_of_depth(int depth) {
    return R"({"asset":{"version":"2.0"},"extras":)" + nested(depth - 1) + "}";
}

TEST(JsonDepth, GltfLoaderTakesExactlyItsLimit) {
    LoadLimits limits;
    limits.max_json_depth = 6;
    ASSERT_EQ(json_nesting_depth(gltf_of_depth(6), 100), 6);
    EXPECT_NO_THROW(parse_gltf(gltf_of_depth(6), false, "", "at_limit.gltf", limits));
    try {
        parse_gltf(gltf_of_depth(7), false, "", "past_limit.gltf", limits);
        ADD_FAILURE() << "a glTF one level past the limit was read";
    } catch (const SceneError& e) {
        EXPECT_EQ(e.where().file, "past_limit.gltf");
        EXPECT_NE(e.detail().find("deeper than 6"), std::string::npos) << e.what();
    }
}

TEST(JsonDepth, GltfLoaderIgnoresBracketsInStrings) {
    LoadLimits limits;
    limits.max_json_depth = 3;
    const std::string text =
        R"({"asset":{"version":"2.0","generator":")" + std::string(200, '[') + R"(\"{{{{"},"extras":{"note":"]]]]"}})";
    EXPECT_NO_THROW(parse_gltf(text, false, "", "strings.gltf", limits));
}

}  // namespace
}  // namespace tessera
