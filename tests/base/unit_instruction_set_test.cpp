// The one choice of the packet kernels' instruction set (base/instruction_set.h): its names, and
// GONIO_PACKET_ISA, which lowers it or is refused. The choice is made once per process, so each
// case that sets the variable runs in a child process of its own (a death test, re-executed).

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "gonio/base/instruction_set.h"

namespace gonio {
namespace {

TEST(InstructionSet, NamesAreTheSetsOfGonioPacketIsa) {
    EXPECT_STREQ(isa_name(Isa::kScalar), "scalar");
    EXPECT_STREQ(isa_name(Isa::kSse2), "sse2");
    EXPECT_STREQ(isa_name(Isa::kAvx2), "avx2");
    EXPECT_STREQ(isa_name(Isa::kAvx512), "avx512");
}

/// In the child: the choice with GONIO_PACKET_ISA = value, as the exit status (the Isa's number).
[[noreturn]] void exit_with_choice_under(const char* value) {
    setenv("GONIO_PACKET_ISA", value, 1);
    std::exit(static_cast<int>(packet_isa()));
}

TEST(InstructionSet, EnvironmentLowersTheChoiceAndNeverRaisesIt) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    // What the processor runs of this build's kernels: 0 (scalar) in a build without them.
    const int here = static_cast<int>(processor_isa());
    auto lowered_to = [&](int set) { return set < here ? set : here; };
    EXPECT_EXIT(exit_with_choice_under("scalar"), testing::ExitedWithCode(0), "");
    EXPECT_EXIT(exit_with_choice_under("sse2"), testing::ExitedWithCode(lowered_to(1)), "");
    EXPECT_EXIT(exit_with_choice_under("avx2"), testing::ExitedWithCode(lowered_to(2)), "");
    EXPECT_EXIT(exit_with_choice_under("avx512"), testing::ExitedWithCode(here), "");
    EXPECT_EXIT(exit_with_choice_under(""), testing::ExitedWithCode(here), "");
}

TEST(InstructionSet, UnknownSetIsRefusedNamingTheVariable) {
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    EXPECT_EXIT(exit_with_choice_under("avx3"),
                testing::ExitedWithCode(2),
                "GONIO_PACKET_ISA=avx3: expected scalar, sse2, avx2 or avx512");
}

}  // namespace
}  // namespace gonio
