#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "gonio/base/data_path.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

// A folder tree of its own under the system's temporary folder (outside any build tree).
class DataPath : public ::testing::Test {
  protected:
    void SetUp() override {
        std::string templ = (fs::temp_directory_path() / "gonio-data-path.XXXXXX").string();
        ASSERT_NE(::mkdtemp(templ.data()), nullptr);
        root_ = templ;
        if (const char* env = std::getenv("GONIO_DATA_DIR"); env != nullptr) {
            saved_env_ = env;
        }
        ::unsetenv("GONIO_DATA_DIR");
    }
    void TearDown() override {
        fs::remove_all(root_);
        if (saved_env_) {
            ::setenv("GONIO_DATA_DIR", saved_env_->c_str(), 1);
        } else {
            ::unsetenv("GONIO_DATA_DIR");
        }
    }
    static void write(const fs::path& p, const std::string& text) {
        fs::create_directories(p.parent_path());
        std::ofstream(p) << text;
    }
    fs::path root_;
    std::optional<std::string> saved_env_;
};

TEST_F(DataPath, BinaryDirIsTheFolderOfThisExecutable) {
    EXPECT_EQ(fs::path(binary_dir()), fs::canonical("/proc/self/exe").parent_path());
}

TEST_F(DataPath, BuildTreeIsFoundUpToThreeFoldersAbove) {
    write(root_ / "build" / "CMakeCache.txt",
          "# comment\nCMAKE_BUILD_TYPE:STRING=Release\ngonio_SOURCE_DIR:STATIC=/src/gonio\n");
    const fs::path deep = root_ / "build" / "a" / "b" / "c";
    fs::create_directories(deep / "d");
    EXPECT_EQ(build_tree_data_dir((root_ / "build").string()), "/src/gonio/data");
    EXPECT_EQ(build_tree_data_dir(deep.string()), "/src/gonio/data");
    EXPECT_EQ(build_tree_data_dir((deep / "d").string()), "");  // four above: not a build tree
}

TEST_F(DataPath, ACacheOfAnotherProjectIsNoBuildTree) {
    write(root_ / "other" / "CMakeCache.txt", "other_SOURCE_DIR:STATIC=/src/other\n");
    fs::create_directories(root_ / "other" / "bin");
    EXPECT_EQ(build_tree_data_dir((root_ / "other" / "bin").string()), "");
    // The nearest cache decides, even when a gonio build tree lies further up.
    write(root_ / "CMakeCache.txt", "gonio_SOURCE_DIR:STATIC=/src/gonio\n");
    EXPECT_EQ(build_tree_data_dir((root_ / "other" / "bin").string()), "");
}

TEST_F(DataPath, CandidatesAreInstallThenEnvironmentThenBuildTree) {
    ::setenv("GONIO_DATA_DIR", root_.c_str(), 1);
    const std::vector<DataDirCandidate> c = data_dir_candidates();
    ASSERT_GE(c.size(), 3u);
    const std::string bin = binary_dir();
    EXPECT_EQ(c.front().origin, "install");
    EXPECT_EQ(c.front().dir, bin + "/../share/gonio");
    EXPECT_EQ(c[c.size() - 2].dir, root_.string());
    EXPECT_EQ(c[c.size() - 2].origin, "$GONIO_DATA_DIR");
    // This test runs from the build tree: its last place is the source tree's data/.
    EXPECT_EQ(c.back().origin, "build tree");
    EXPECT_EQ(fs::canonical(c.back().dir), fs::canonical(fs::path(GONIO_SOURCE_DIR) / "data"));
}

TEST_F(DataPath, EnvironmentComesBeforeTheBuildTree) {
    write(root_ / "materials" / "ngan2005.json", "{}");
    ::setenv("GONIO_DATA_DIR", root_.c_str(), 1);
    Expected<std::string> found = find_data_file("materials/ngan2005.json");
    ASSERT_TRUE(found) << found.error().message;
    EXPECT_EQ(*found, (root_ / "materials" / "ngan2005.json").string());
    // Without the variable, the build tree's source data.
    ::unsetenv("GONIO_DATA_DIR");
    found = find_data_file("materials/ngan2005.json");
    ASSERT_TRUE(found) << found.error().message;
    EXPECT_EQ(fs::canonical(*found),
              fs::canonical(fs::path(GONIO_SOURCE_DIR) / "data" / "materials" / "ngan2005.json"));
}

TEST_F(DataPath, TheErrorListsEveryPlaceTried) {
    ::setenv("GONIO_DATA_DIR", root_.c_str(), 1);
    Expected<std::string> found = find_data_file("materials/none.json");
    ASSERT_FALSE(found);
    const std::string& m = found.error().message;
    EXPECT_NE(m.find("data file \"materials/none.json\" not found"), std::string::npos) << m;
    EXPECT_NE(m.find(binary_dir() + "/../share/gonio/materials/none.json (install)"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find(root_.string() + "/materials/none.json ($GONIO_DATA_DIR)"), std::string::npos)
        << m;
    EXPECT_NE(m.find("/data/materials/none.json (build tree)"), std::string::npos) << m;
}

}  // namespace
}  // namespace gonio
