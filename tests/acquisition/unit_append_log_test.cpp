// The file underneath both campaign journals: records replayed in order, a last record never
// acknowledged cut off before appending, corruption refused with the file left as it was, a
// symbolic link at the journal's name refused, appends durable in order.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "gonio/acquisition/shared/append_log.h"

namespace gonio::acquisition {
namespace {

std::string temp_path(const std::string& name) {
    return (std::filesystem::temp_directory_path() /
            ("gonio_append_log_" + name + "_" + std::to_string(::getpid())))
        .string();
}

std::string read_all(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

/// Records are lines; a line without its newline is a torn tail; a line "bad" with more after it
/// is corruption.
struct Lines {
    std::vector<std::string> seen;
    AppendLog::NextRecord next() {
        return [this](const std::string& content,
                      std::size_t pos) -> Expected<std::optional<std::size_t>> {
            const std::size_t nl = content.find('\n', pos);
            if (nl == std::string::npos) {
                return std::optional<std::size_t>();
            }
            const std::string line = content.substr(pos, nl - pos);
            if (line == "bad") {
                return make_error("line " + std::to_string(seen.size() + 1) + " is bad");
            }
            seen.push_back(line);
            return std::optional<std::size_t>(nl + 1);
        };
    }
};

TEST(AppendLog, ReplaysRecordsCutsTheTornTailAndAppendsAfterTheGoodOnes) {
    const std::string path = temp_path("torn");
    std::ofstream(path, std::ios::binary) << "one\ntwo\nthr";
    Lines lines;
    bool torn = false;
    auto log = AppendLog::replay(path, lines.next(), &torn);
    ASSERT_TRUE(log) << log.error().message;
    EXPECT_EQ(lines.seen, (std::vector<std::string>{"one", "two"}));
    EXPECT_TRUE(torn);
    // The torn record is gone from the file before anything is appended.
    EXPECT_EQ(read_all(path), "one\ntwo\n");
    ASSERT_TRUE(log->append("three\n"));
    ASSERT_TRUE(log->append("four\n"));
    EXPECT_EQ(read_all(path), "one\ntwo\nthree\nfour\n");
    EXPECT_EQ(log->path(), path);
    // Read back whole: nothing torn.
    Lines again;
    auto reopened = AppendLog::replay(path, again.next(), &torn);
    ASSERT_TRUE(reopened) << reopened.error().message;
    EXPECT_FALSE(torn);
    EXPECT_EQ(again.seen, (std::vector<std::string>{"one", "two", "three", "four"}));
    std::filesystem::remove(path);
}

TEST(AppendLog, MissingFileIsCreatedEmpty) {
    const std::string path = temp_path("new");
    std::filesystem::remove(path);
    Lines lines;
    bool torn = true;
    auto log = AppendLog::replay(path, lines.next(), &torn);
    ASSERT_TRUE(log) << log.error().message;
    EXPECT_FALSE(torn);
    EXPECT_TRUE(lines.seen.empty());
    EXPECT_TRUE(std::filesystem::exists(path));
    ASSERT_TRUE(log->append("first\n"));
    EXPECT_EQ(read_all(path), "first\n");
    std::filesystem::remove(path);
}

TEST(AppendLog, CorruptionIsAnErrorAndLeavesTheFileAsItWas) {
    const std::string path = temp_path("corrupt");
    const std::string content = "one\nbad\nthree\n";
    std::ofstream(path, std::ios::binary) << content;
    Lines lines;
    bool torn = false;
    auto log = AppendLog::replay(path, lines.next(), &torn);
    ASSERT_FALSE(log);
    EXPECT_EQ(log.error().message, "line 2 is bad");
    EXPECT_EQ(read_all(path), content);
    std::filesystem::remove(path);
}

TEST(AppendLog, SymbolicLinkAtTheJournalsNameIsRefused) {
    const std::string target = temp_path("target");
    const std::string link = temp_path("link");
    std::filesystem::remove(link);
    std::ofstream(target, std::ios::binary) << "kept\n";
    std::filesystem::create_symlink(target, link);
    Lines lines;
    bool torn = false;
    auto log = AppendLog::replay(link, lines.next(), &torn);
    ASSERT_FALSE(log);
    EXPECT_NE(log.error().message.find(link + ": cannot open"), std::string::npos)
        << log.error().message;
    EXPECT_TRUE(lines.seen.empty());
    EXPECT_EQ(read_all(target), "kept\n");
    std::filesystem::remove(link);
    std::filesystem::remove(target);
}

}  // namespace
}  // namespace gonio::acquisition
