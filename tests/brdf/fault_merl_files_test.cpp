// Broken MERL / table files: every case gives an error naming the file and the problem.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "gonio/brdf/merl.h"
#include "gonio/brdf/samples_io.h"

namespace gonio::brdf {
namespace {

namespace fs = std::filesystem;

std::string corpus(const std::string& name) {
    return std::string(GONIO_SOURCE_DIR) + "/tests/brdf/data/merl/" + name;
}

// Reads `path` and expects an error whose message names the file and contains `what`.
void expect_error(const std::string& path, const std::string& what) {
    Expected<TabulatedBrdf> t = read_table_file(path);
    ASSERT_FALSE(t) << path << " was accepted";
    EXPECT_NE(t.error().message.find(path), std::string::npos) << t.error().message;
    EXPECT_NE(t.error().message.find(what), std::string::npos)
        << "expected \"" << what << "\" in: " << t.error().message;
}

TEST(MerlFaults, MissingFile) {
    expect_error(corpus("no_such_file.binary"), "no such file");
}

TEST(MerlFaults, Directory) {
    const std::string dir =
        fs::temp_directory_path() /
        ("gonio_merl_dir_" + std::to_string(static_cast<long>(::getpid())) + ".binary");
    fs::create_directories(dir);
    expect_error(dir, "is a directory");
    fs::remove(dir);
}

TEST(MerlFaults, EmptyAndShortHeader) {
    expect_error(corpus("empty.binary"), "0 bytes, shorter than the 12-byte header");
    expect_error(corpus("short_header.binary"), "7 bytes, shorter than the 12-byte header");
}

TEST(MerlFaults, WrongDims) {
    expect_error(corpus("wrong_dims.binary"),
                 "header dims are 90, 90, 90, the MERL format requires 90, 90, 180");
    expect_error(corpus("negative_dims.gtab"),
                 "header dims are -2, 2, 2, each must be in [1, 4096]");
    expect_error(corpus("zero_dims.gtab"), "header dims are 2, 0, 2");
    expect_error(corpus("huge_dims.gtab"), "header dims are 5000, 2, 2");
}

TEST(MerlFaults, TruncatedAndTrailing) {
    expect_error(corpus("truncated.binary"),
                 "204 bytes, dims 90 x 90 x 180 require 34992012 (truncated)");
    expect_error(corpus("truncated.gtab"), "199 bytes, dims 2 x 2 x 2 require 204 (truncated)");
    expect_error(corpus("trailing.gtab"), "205 bytes, dims 2 x 2 x 2 require 204 (trailing bytes)");
}

TEST(MerlFaults, NonFiniteEntriesNamed) {
    // nan.gtab: entry 13 = green (13 / 8 = 1), flat 5 = (theta_h 1, theta_d 0, phi_d 1).
    expect_error(corpus("nan.gtab"),
                 "entry 13 (channel g, theta_h bin 1, theta_d bin 0, phi_d bin 1) is NaN");
    // inf.gtab: entry 18 = blue, flat 2 = (0, 1, 0).
    expect_error(corpus("inf.gtab"),
                 "entry 18 (channel b, theta_h bin 0, theta_d bin 1, phi_d bin 0) is infinite");
}

TEST(MerlFaults, NanInFullSizeFile) {
    // A full-size image with one NaN in the red block at bin (89, 89, 179) (the very last one).
    const TableGrid g = TableGrid::merl();
    std::vector<std::uint8_t> bytes(merl_file_size(g), 0);
    const std::int32_t dims[3] = {90, 90, 180};
    std::memcpy(bytes.data(), dims, 12);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::memcpy(bytes.data() + 12 + 8 * (g.size() - 1), &nan, 8);
    Expected<TabulatedBrdf> t = parse_merl(bytes.data(), bytes.size(), "img.binary");
    ASSERT_FALSE(t);
    EXPECT_NE(t.error().message.find("img.binary: entry 1457999 (channel r, theta_h bin 89, "
                                     "theta_d bin 89, phi_d bin 179) is NaN"),
              std::string::npos)
        << t.error().message;
}

TEST(MerlFaults, WrongExtensionAndWriteErrors) {
    EXPECT_FALSE(read_table_file("x.csv"));
    Expected<Dataset> d = load_samples("data.txt");
    ASSERT_FALSE(d);
    EXPECT_NE(d.error().message.find("data.txt: unknown sample file type"), std::string::npos);
    // load_samples passes the reader's error through.
    Expected<Dataset> e = load_samples(corpus("truncated.gtab"));
    ASSERT_FALSE(e);
    EXPECT_NE(e.error().message.find("(truncated)"), std::string::npos);
    // A coarse grid cannot be written under a MERL name, and an unwritable path is an error.
    const TabulatedBrdf small = TabulatedBrdf::empty(TableGrid{2, 2, 2}, kMerlScale, "small");
    Expected<void> w = write_merl("small.binary", small);
    ASSERT_FALSE(w);
    EXPECT_NE(w.error().message.find("cannot be written as MERL"), std::string::npos);
    Expected<void> w2 = write_merl(corpus("empty.binary") + "/x.gtab", small);
    ASSERT_FALSE(w2);
    EXPECT_NE(w2.error().message.find("empty.binary is not a folder"), std::string::npos)
        << w2.error().message;
}

}  // namespace
}  // namespace gonio::brdf
