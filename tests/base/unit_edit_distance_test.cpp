// edit_distance against distances worked out by hand from the definition (fewest single-character
// insertions, deletions and substitutions).

#include <gtest/gtest.h>

#include "gonio/base/edit_distance.h"

namespace {

TEST(EditDistance, WorkedExamples) {
    EXPECT_EQ(gonio::edit_distance("", ""), 0u);
    EXPECT_EQ(gonio::edit_distance("", "fit"), 3u);     // three insertions
    EXPECT_EQ(gonio::edit_distance("report", ""), 6u);  // six deletions
    EXPECT_EQ(gonio::edit_distance("acquire", "acquire"), 0u);
    EXPECT_EQ(gonio::edit_distance("kitten", "sitting"), 3u);  // k->s, e->i, +g
    EXPECT_EQ(gonio::edit_distance("fti", "fit"), 2u);         // no transposition step
    EXPECT_EQ(gonio::edit_distance("red-plastc", "red-plastic"), 1u);
}

TEST(EditDistance, IsSymmetric) {
    EXPECT_EQ(gonio::edit_distance("convert", "cnovret"),
              gonio::edit_distance("cnovret", "convert"));
}

}  // namespace
