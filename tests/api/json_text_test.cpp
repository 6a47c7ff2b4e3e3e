// json_text and parse_json: every tree a client or a file can fill becomes valid JSON text
// (invalid UTF-8 replaced, never thrown on; non-finite numbers as null), and a text is parsed,
// refused as not JSON, or refused as too deep before any tree is built.
#include "api/json_text.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <string>

namespace tessera::api {
namespace {

using nlohmann::json;

const std::string kReplacement = "\xEF\xBF\xBD";  // U+FFFD in UTF-8

// The text json_text makes must read back with a strict parser: what a client receives.
json reparsed(const std::string& text) {
    const std::optional<json> j = parse_json(text, 64);
    EXPECT_TRUE(j.has_value()) << "json_text made text that is not JSON: " << text;
    return j.value_or(json());
}

TEST(JsonText, ValidTextIsNlohmannsDump) {
    const json j = {{"a", 1}, {"b", json::array({true, nullptr, "x"})}};
    EXPECT_EQ(json_text(j), R"({"a":1,"b":[true,null,"x"]})");
    EXPECT_EQ(json_text(j, 2), j.dump(2));
    EXPECT_EQ(json_text(json{{"a", 1}}, 2), "{\n  \"a\": 1\n}");
}

// Non-ASCII text is written as UTF-8, not as \u escapes: the answer stays readable, and a name
// compares equal byte for byte after a round trip.
TEST(JsonText, ValidUtf8PassesThroughUnescaped) {
    const std::string name = "caf\xC3\xA9 \xE2\x80\x94 \xF0\x9F\x98\x80";  // é, em dash, an emoji (4 bytes)
    EXPECT_EQ(json_text(json(name)), "\"" + name + "\"");
    EXPECT_EQ(reparsed(json_text(json(name))), name);
}

// A client's bytes that are not UTF-8 (a path, a job id) are answered with U+FFFD in their place:
// the rest of the string survives and the text is JSON.
TEST(JsonText, InvalidUtf8IsReplacedNotThrown) {
    const json bad = std::string("a\xFFz");
    ASSERT_THROW((void)bad.dump(), json::type_error) << "the premise: nlohmann's own dump throws";
    std::string text;
    ASSERT_NO_THROW(text = json_text(bad));
    EXPECT_EQ(text, "\"a" + kReplacement + "z\"");
    EXPECT_EQ(reparsed(text), "a" + kReplacement + "z");
}

TEST(JsonText, InvalidUtf8InAnObjectKeyIsReplacedToo) {
    json j = json::object();
    j[std::string("k\xFE")] = 1;
    const std::string text = json_text(j);
    EXPECT_EQ(text, "{\"k" + kReplacement + "\":1}");
    EXPECT_EQ(reparsed(text).at("k" + kReplacement), 1);
}

TEST(JsonText, InvalidUtf8NestedDeepInATreeIsReplaced) {
    const json j = {{"errors", json::array({json{{"detail", std::string("no such file /tmp/\xC3")}}})}};
    const json back = reparsed(json_text(j, 2));
    EXPECT_EQ(back["errors"][0]["detail"], "no such file /tmp/" + kReplacement);
}

// A sequence cut short by an ASCII byte loses the cut sequence only: the ASCII byte after it is
// read again, not swallowed with it.
TEST(JsonText, ATruncatedSequenceKeepsTheByteAfterIt) {
    EXPECT_EQ(reparsed(json_text(json(std::string("\xE2\x82z")))), kReplacement + "z");
    EXPECT_EQ(reparsed(json_text(json(std::string("ab\xE2\x82")))), "ab" + kReplacement) << "cut at the end";
}

// An overlong encoding of '/' must not decode to '/' (the classic path-traversal disguise).
TEST(JsonText, OverlongEncodingsDoNotDecodeToAscii) {
    const std::string out = reparsed(json_text(json(std::string("a\xC0\xAF" "b")))).get<std::string>();
    EXPECT_EQ(out.find('/'), std::string::npos) << out;
    EXPECT_EQ(out.front(), 'a');
    EXPECT_EQ(out.back(), 'b');
    EXPECT_NE(out.find(kReplacement), std::string::npos);
}

// A NUL or a line break in a string is escaped, not cut or passed through raw.
TEST(JsonText, ControlCharactersAreEscaped) {
    const std::string s("a\0b\nc", 5);
    const std::string text = json_text(json(s));
    EXPECT_EQ(text, "\"a\\u0000b\\nc\"");
    EXPECT_EQ(reparsed(text), s);
}

// JSON has no NaN or infinity: a non-finite statistic is written as null, so the text stays JSON.
TEST(JsonText, NonFiniteNumbersAreWrittenAsNull) {
    const json j = {{"nan", std::numeric_limits<double>::quiet_NaN()},
                    {"inf", std::numeric_limits<double>::infinity()},
                    {"minus_inf", -std::numeric_limits<double>::infinity()},
                    {"finite", 0.5}};
    const std::string text = json_text(j);
    EXPECT_EQ(text, R"({"finite":0.5,"inf":null,"minus_inf":null,"nan":null})");
    const json back = reparsed(text);
    EXPECT_TRUE(back["nan"].is_null());
    EXPECT_TRUE(back["inf"].is_null());
    EXPECT_EQ(back["finite"], 0.5);
}

// Doubles are written with enough digits to read back exactly (a farm keeps its curve as text).
TEST(JsonText, DoublesRoundTripExactly) {
    for (const double d : {0.1, 1.0 / 3.0, 2.0 / 3.0 * 1e-7, 123456789.123456789, 5e-324, 1.7976931348623157e308}) {
        const json back = reparsed(json_text(json(d)));
        EXPECT_EQ(back.get<double>(), d) << json_text(json(d));
    }
}

TEST(ParseJson, ParsesJson) {
    const std::optional<json> j = parse_json(R"(  {"a": [1, 2.5, "x"], "b": null}  )", 4);
    ASSERT_TRUE(j.has_value());
    EXPECT_EQ(*j, (json{{"a", {1, 2.5, "x"}}, {"b", nullptr}}));
    const std::optional<json> scalar = parse_json("42", 0);
    ASSERT_TRUE(scalar.has_value()) << "a scalar nests 0 deep";
    EXPECT_EQ(*scalar, 42);
}

// Whatever is not JSON is an empty answer, never an exception the caller must know about.
TEST(ParseJson, NotJsonIsNothing) {
    for (const std::string text : {"", "   ", "{", "[1,]", "{\"a\":1,}", "{\"a\" 1}", "{} x", "NaN", "Infinity", "'a'",
                                   "{\"a\":01}", "1e400", "\"\\ud800\"", "\"a\xFF\"", "\"unterminated"}) {
        std::optional<json> j;
        EXPECT_NO_THROW(j = parse_json(text, 8)) << text;
        EXPECT_FALSE(j.has_value()) << "taken as JSON: " << text;
    }
}

TEST(ParseJson, TheBoundIsInclusive) {
    EXPECT_TRUE(parse_json("[[[1]]]", 3).has_value());
    EXPECT_TRUE(parse_json(R"({"a":{"b":[1]}})", 3).has_value());
    EXPECT_THROW(parse_json("[[[[1]]]]", 3), JsonTooDeep);
    EXPECT_THROW(parse_json(R"({"a":{"b":[{}]}})", 3), JsonTooDeep);
}

// A key twice in one object is refused, at any depth; the same key in two objects is not.
TEST(ParseJson, AKeyTwiceInOneObjectIsRefused) {
    EXPECT_THROW(parse_json(R"({"spp":1,"spp":4096})", 8), JsonDuplicateKey);
    EXPECT_THROW(parse_json(R"({"a":[{"b":1},{"c":{"d":1,"d":2}}]})", 8), JsonDuplicateKey);
    EXPECT_TRUE(parse_json(R"({"a":{"k":1},"b":{"k":2},"k":[{"k":3},{"k":4}]})", 8).has_value());
    try {
        parse_json(R"({"scene":"x","spp":1,"spp":2})", 8);
        ADD_FAILURE() << "no JsonDuplicateKey";
    } catch (const JsonDuplicateKey& e) {
        EXPECT_NE(std::string(e.what()).find("\"spp\""), std::string::npos) << e.what();
    }
}

TEST(ParseJson, TooDeepSaysItsBound) {
    try {
        parse_json("[[[[[[[[[[]]]]]]]]]]", 7);
        FAIL() << "not refused";
    } catch (const JsonTooDeep& e) {
        EXPECT_EQ(e.max_depth, 7);
        EXPECT_STREQ(e.what(), "the JSON nests arrays and objects deeper than 7 levels, the bound");
    }
}

// The depth is judged on the bytes, before parsing: an unclosed flood of brackets (which the
// parser would refuse anyway) is refused as too deep, and a deep text is refused even when it
// would not parse.
TEST(ParseJson, DepthIsCheckedBeforeParsing) {
    EXPECT_THROW(parse_json(std::string(100000, '['), 64), JsonTooDeep);
    EXPECT_THROW(parse_json("[[[[[ this is not JSON", 3), JsonTooDeep);
    EXPECT_FALSE(parse_json("[[ this is not JSON", 3).has_value()) << "shallow enough: just not JSON";
}

// Brackets inside strings are text, not nesting; an escaped quote does not end a string, and an
// escaped backslash does not escape the quote after it.
TEST(ParseJson, BracketsInStringsDoNotCount) {
    const std::optional<json> text = parse_json(R"("[[[[[[[[")", 0);
    ASSERT_TRUE(text.has_value()) << "a string nests 0 deep";
    EXPECT_EQ(*text, "[[[[[[[[");
    EXPECT_TRUE(parse_json(R"(["]]]]", ["x"]])", 2).has_value()) << "closing brackets in a string do not lower the depth";
    EXPECT_THROW(parse_json(R"(["]]]]", [["x"]]])", 2), JsonTooDeep);
    EXPECT_TRUE(parse_json(R"(["a\"[[[[", 1])", 1).has_value()) << "an escaped quote keeps the string open";
    EXPECT_THROW(parse_json(R"(["\\", [[[1]]]])", 3), JsonTooDeep) << "after \\\\ the quote closes the string";
}

}  // namespace
}  // namespace tessera::api
