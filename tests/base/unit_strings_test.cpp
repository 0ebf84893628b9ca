#include <gtest/gtest.h>

#include "gonio/base/strings.h"

namespace gonio {
namespace {

TEST(Strings, EndsWithMatchesOnlyTheTail) {
    EXPECT_TRUE(ends_with("fit.json", ".json"));
    EXPECT_TRUE(ends_with("fit.json", ""));
    EXPECT_TRUE(ends_with(".json", ".json"));
    EXPECT_FALSE(ends_with("json", ".json"));
    EXPECT_FALSE(ends_with("fit.json.tmp", ".json"));
    EXPECT_FALSE(ends_with("", "x"));
}

TEST(Strings, TrimTakesOffBlanksAtBothEndsOnly) {
    EXPECT_EQ(trim("  theta_i\t"), "theta_i");
    EXPECT_EQ(trim("\r\n a b \r\n"), "a b");
    EXPECT_EQ(trim("x"), "x");
    EXPECT_EQ(trim(" \t\r\n"), "");
    EXPECT_EQ(trim(""), "");
    EXPECT_EQ(trim("\va\f"), "\va\f");  // only space, tab, CR and LF are blanks
}

TEST(Strings, StartsWithMatchesOnlyTheHead) {
    EXPECT_TRUE(starts_with("gige://127.0.0.1", "gige://"));
    EXPECT_TRUE(starts_with("x", ""));
    EXPECT_FALSE(starts_with("gig", "gige://"));
    EXPECT_FALSE(starts_with("a-gige://", "gige://"));
}

TEST(Strings, ExcerptCutsLongQuotesAndSaysHowLong) {
    EXPECT_EQ(excerpt("theta_x"), "theta_x");
    const std::string digits(80, '7');
    EXPECT_EQ(excerpt(digits), std::string(32, '7') + "... (80 bytes)");
    EXPECT_EQ(excerpt(std::string(32, 'a')), std::string(32, 'a'));  // at the bound: whole
    EXPECT_EQ(excerpt("abcdef", 3), "abc... (6 bytes)");
    // "\xC3\xA9" is one character (e-acute): a cut after 4 bytes would split it, so it ends before.
    EXPECT_EQ(excerpt("abc\xC3\xA9xyz", 4), "abc... (8 bytes)");
    EXPECT_EQ(excerpt("abc\xC3\xA9xyz", 5), "abc\xC3\xA9... (8 bytes)");
    // Control bytes and bytes that are not UTF-8 are escaped: no NUL ends the message early.
    EXPECT_EQ(excerpt(std::string("a\0b\xFF", 4)), "a\\x00b\\xFF");
    EXPECT_EQ(excerpt("tab\there"), "tab\\x09here");
}

TEST(Strings, JsonErrorTextDropsTheCodeAndCutsTheQuote) {
    // The form of nlohmann::json's parse errors.
    const std::string long_token = "\"" + std::string(2000, '7');
    const std::string what =
        "[json.exception.parse_error.101] parse error at line 1, column 2001: "
        "syntax error while parsing object key - invalid literal; last read: '" +
        long_token + "'; expected string literal";
    const std::string text = json_error_text(what);
    EXPECT_EQ(text,
              "parse error at line 1, column 2001: syntax error while parsing object key - invalid "
              "literal; last read: '\"" +
                  std::string(31, '7') + "... (2001 bytes)'; expected string literal");
    // A quote that itself holds "'; expected" far from the end is still cut whole.
    const std::string tricky =
        "[json.exception.parse_error.101] parse error at line 1, column 9: "
        "syntax error while parsing value - invalid string; last read: '\"ab"
        "'; expected x" +
        std::string(100, 'y') + "'";
    EXPECT_EQ(json_error_text(tricky),
              "parse error at line 1, column 9: syntax error while parsing value - invalid string; "
              "last read: '\"ab'; expected x" +
                  std::string(16, 'y') + "... (116 bytes)'");
    // Without a quote or a code: unchanged.
    EXPECT_EQ(json_error_text("[json.exception.type_error.302] type must be number, but is string"),
              "type must be number, but is string");
    EXPECT_EQ(json_error_text("plain"), "plain");
    // A number out of the double range is quoted after "number overflow parsing '" (the fuzz
    // corpus's finding_number_overflow_quoted_whole.json quoted 5,000 digits).
    EXPECT_EQ(json_error_text("[json.exception.out_of_range.406] number overflow parsing '" +
                              std::string(400, '5') + "'"),
              "number overflow parsing '" + std::string(32, '5') + "... (400 bytes)'");
}

}  // namespace
}  // namespace gonio
