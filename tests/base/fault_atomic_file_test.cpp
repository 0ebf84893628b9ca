// AtomicFile and the output checks: links are never followed, nothing is left behind on failure,
// the previous file survives a failed write, folders and devices are refused, limits and memory
// budget messages are in human units.

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "gonio/base/atomic_file.h"
#include "gonio/base/limits.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

class AtomicFileTest : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::path(GONIO_BINARY_DIR) / "tests" /
               ("atomic_" +
                std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    std::string p(const std::string& name) const { return (dir_ / name).string(); }
    static std::string slurp(const std::string& path) {
        std::ifstream in(path, std::ios::binary);
        std::stringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }
    std::size_t entries() const {
        return static_cast<std::size_t>(
            std::distance(fs::directory_iterator(dir_), fs::directory_iterator()));
    }
    fs::path dir_;
};

TEST_F(AtomicFileTest, WritesReplacesAndLeavesOnlyTheTarget) {
    ASSERT_TRUE(write_file_atomic(p("a.txt"), "first"));
    ASSERT_TRUE(write_file_atomic(p("a.txt"), "second"));
    EXPECT_EQ(slurp(p("a.txt")), "second");
    EXPECT_EQ(entries(), 1u);
    struct stat st {};
    ASSERT_EQ(::stat(p("a.txt").c_str(), &st), 0);
    EXPECT_TRUE(S_ISREG(st.st_mode));
}

TEST_F(AtomicFileTest, TemporaryFileIsHiddenRandomAndRemovedWithoutCommit) {
    {
        Expected<AtomicFile> f = AtomicFile::create(p("b.csv"));
        ASSERT_TRUE(f) << f.error().message;
        const std::string tmp = fs::path(f->temp_path()).filename().string();
        EXPECT_EQ(tmp.rfind(".b.csv.", 0), 0u) << tmp;
        EXPECT_EQ(tmp.size(), std::string(".b.csv.").size() + 16 + 4) << tmp;
        Expected<AtomicFile> g = AtomicFile::create(p("b.csv"));
        ASSERT_TRUE(g);
        EXPECT_NE(f->temp_path(), g->temp_path());
        ASSERT_TRUE(f->write("partial"));
        EXPECT_EQ(entries(), 2u);
    }
    EXPECT_EQ(entries(), 0u);
    EXPECT_FALSE(fs::exists(p("b.csv")));
}

TEST_F(AtomicFileTest, LinkAtTheFinalNameIsReplacedAndItsTargetUntouched) {
    const std::string victim = p("victim");
    std::ofstream(victim) << "precious";
    fs::create_symlink(victim, p("out.json"));
    ASSERT_TRUE(write_file_atomic(p("out.json"), "new"));
    EXPECT_EQ(slurp(victim), "precious");
    EXPECT_FALSE(fs::is_symlink(p("out.json")));
    EXPECT_EQ(slurp(p("out.json")), "new");
}

TEST_F(AtomicFileTest, FoldersDevicesAndMissingFoldersAreRefused) {
    fs::create_directories(p("sub"));
    Expected<void> a = check_output_path(p("sub"));
    ASSERT_FALSE(a);
    EXPECT_NE(a.error().message.find("output path is a folder"), std::string::npos);
    Expected<void> b = check_output_path("/dev/null");
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("/dev/null: output path is a device"), std::string::npos);
    fs::create_symlink("/dev/null", p("devlink"));
    Expected<void> c = check_output_path(p("devlink"));
    ASSERT_FALSE(c);
    EXPECT_NE(c.error().message.find("link to a device"), std::string::npos);
    Expected<void> d = write_file_atomic(p("nope/x.txt"), "x");
    ASSERT_FALSE(d);
    EXPECT_NE(d.error().message.find("does not exist"), std::string::npos);
    EXPECT_FALSE(check_output_path(""));
    EXPECT_TRUE(check_output_path(p("fresh.txt")));
}

// A write that fails part way (file size limit: EFBIG, as a full disk gives ENOSPC) keeps the
// previous file and leaves no temporary file. Run in a child so the limit stays there.
TEST_F(AtomicFileTest, FailedWriteKeepsThePreviousFileAndLeavesNoDebris) {
    ASSERT_TRUE(write_file_atomic(p("keep.csv"), "old content\n"));
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        ::signal(SIGXFSZ, SIG_IGN);
        struct rlimit rl {
            4096, 4096
        };
        ::setrlimit(RLIMIT_FSIZE, &rl);
        Expected<void> w = write_file_atomic(p("keep.csv"), std::string(100000, 'x'));
        const bool says = !w && w.error().message.find("write failed") != std::string::npos &&
                          w.error().message.find("keep.csv") != std::string::npos;
        _exit(says ? 0 : 3);
    }
    int st = 0;
    ASSERT_EQ(waitpid(pid, &st, 0), pid);
    ASSERT_TRUE(WIFEXITED(st));
    EXPECT_EQ(WEXITSTATUS(st), 0) << "the write did not fail with a message naming the file";
    EXPECT_EQ(slurp(p("keep.csv")), "old content\n");
    EXPECT_EQ(entries(), 1u);
}

TEST(Limits, HumanUnitsAndByteSizes) {
    EXPECT_EQ(human_bytes(17), "17 B");
    EXPECT_EQ(human_bytes(1536), "1.5 KiB");
    EXPECT_EQ(human_bytes(2.0 * 1024 * 1024 * 1024), "2 GiB");
    EXPECT_EQ(show_number(1.7976931348623157e308), "1.79769e+308");
    EXPECT_EQ(*parse_byte_size("512M"), std::size_t{512} << 20);
    EXPECT_EQ(*parse_byte_size("4GiB"), std::size_t{4} << 30);
    EXPECT_EQ(*parse_byte_size("1.5G"), std::size_t{3} << 29);
    EXPECT_FALSE(parse_byte_size("12X"));
    EXPECT_FALSE(parse_byte_size("-1G"));
    EXPECT_FALSE(parse_byte_size("nanG"));
    EXPECT_FALSE(parse_byte_size("10"));  // below 1 MiB
}

TEST(Limits, MemoryBudgetIsCheckedAndOverridable) {
    const std::size_t saved = max_memory_bytes();
    EXPECT_EQ(saved, kDefaultMaxMemoryBytes);
    Expected<void> big = check_memory(1.5 * 1024.0 * 1024 * 1024 * 1024, "a 4096^3 table");
    ASSERT_FALSE(big);
    EXPECT_EQ(big.error().message,
              "a 4096^3 table needs about 1.5 TiB of memory, above the limit of 2 GiB (raise it "
              "with --max-memory, e.g. --max-memory 8G)");
    set_max_memory_bytes(std::size_t{4} << 40);
    EXPECT_TRUE(check_memory(1.5 * 1024.0 * 1024 * 1024 * 1024, "a 4096^3 table"));
    set_max_memory_bytes(saved);
    EXPECT_FALSE(check_memory(std::nan(""), "NaN bytes"));
}

TEST(Limits, JsonDepthIsCountedOutsideStrings) {
    std::string ok = std::string(64, '[') + std::string(64, ']');
    EXPECT_TRUE(check_json_text(ok, "a.json"));
    std::string deep = std::string(65, '[') + std::string(65, ']');
    Expected<void> e = check_json_text(deep, "a.json");
    ASSERT_FALSE(e);
    EXPECT_EQ(e.error().message, "a.json:1: objects and arrays nested deeper than 64 levels");
    // Brackets inside strings (with escaped quotes) do not count.
    EXPECT_TRUE(check_json_text("{\"k\": \"\\\"" + std::string(1000, '[') + "\"}", "b.json"));
}

}  // namespace
}  // namespace gonio
