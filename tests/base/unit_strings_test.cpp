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

TEST(Strings, StartsWithMatchesOnlyTheHead) {
    EXPECT_TRUE(starts_with("gige://127.0.0.1", "gige://"));
    EXPECT_TRUE(starts_with("x", ""));
    EXPECT_FALSE(starts_with("gig", "gige://"));
    EXPECT_FALSE(starts_with("a-gige://", "gige://"));
}

}  // namespace
}  // namespace gonio
