// The dataset CSV reader: exact round trip, line numbers across the parallel chunks, strict errors
// that name file, line, column and the allowed range, and the keep-going mode that lists the rows
// it refused (Dataset::rejected) instead.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "gonio/brdf/dataset.h"
#include "gonio/brdf/samples_io.h"

namespace gonio::brdf {
namespace {

namespace fs = std::filesystem;

std::string temp_path(const std::string& name) {
    const fs::path dir =
        fs::temp_directory_path() /
        ("gonio_samples_csv_test_" + std::to_string(static_cast<long>(::getpid())));
    fs::create_directories(dir);
    return (dir / name).string();
}

std::string write(const std::string& name, const std::string& text) {
    const std::string p = temp_path(name);
    std::ofstream(p, std::ios::binary) << text;
    return p;
}

/// A seeded dataset of n rows with every optional column.
Dataset random_dataset(std::size_t n) {
    Dataset d;
    d.has_sigma = d.has_weight = d.has_flags = true;
    std::mt19937_64 rng(42);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (std::size_t i = 0; i < n; ++i) {
        Sample s;
        s.theta_i = 1.5 * u(rng);
        s.phi_i = 6 * u(rng) - 3;
        s.theta_o = 1.5 * u(rng);
        s.phi_o = 6 * u(rng) - 3;
        s.value = Rgbd(u(rng), 1e3 * u(rng), 1e-9 * u(rng));
        s.sigma = 0.01 * s.value;
        s.weight = u(rng);
        s.flags = static_cast<std::uint32_t>(rng() & 0xf);
        d.samples.push_back(s);
    }
    return d;
}

TEST(SamplesCsv, RoundTripIsBitExactAcrossParallelChunks) {
    // 40 000 rows (about 7 MB): large enough to be parsed in several chunks.
    const Dataset d = random_dataset(40000);
    const std::string p = temp_path("round.csv");
    ASSERT_TRUE(write_dataset_csv(p, d));
    Expected<Dataset> back = read_dataset_csv(p);
    ASSERT_TRUE(back) << back.error().message;
    ASSERT_EQ(back->samples.size(), d.samples.size());
    EXPECT_TRUE(back->has_sigma && back->has_weight && back->has_flags);
    for (std::size_t i = 0; i < d.samples.size(); ++i) {
        const Sample& a = d.samples[i];
        const Sample& b = back->samples[i];
        ASSERT_EQ(a.theta_i, b.theta_i) << i;
        ASSERT_EQ(a.phi_o, b.phi_o) << i;
        ASSERT_EQ(a.value[1], b.value[1]) << i;
        ASSERT_EQ(a.value[2], b.value[2]) << i;
        ASSERT_EQ(a.sigma[0], b.sigma[0]) << i;
        ASSERT_EQ(a.weight, b.weight) << i;
        ASSERT_EQ(a.flags, b.flags) << i;
        ASSERT_EQ(b.line, i + 2) << i;  // header on line 1
    }
}

TEST(SamplesCsv, CommentsBlankLinesCrlfColumnOrderAndSpacesAreAccepted) {
    const std::string p = write("forms.csv",
                                "# a comment\r\n"
                                "\r\n"
                                " r , g,b,theta_i,phi_i,theta_o,phi_o\r\n"
                                "0.5, 0.25 ,+1e-1,0.1,0,0.2,3.14\r\n"
                                "   \n"
                                "# another\n"
                                "1,2,3,0,0,0,0");
    Expected<Dataset> d = read_dataset_csv(p);
    ASSERT_TRUE(d) << d.error().message;
    ASSERT_EQ(d->samples.size(), 2u);
    EXPECT_EQ(d->samples[0].value[0], 0.5);
    EXPECT_EQ(d->samples[0].value[2], 0.1);
    EXPECT_EQ(d->samples[0].theta_o, 0.2);
    EXPECT_EQ(d->samples[0].line, 4u);
    EXPECT_EQ(d->samples[1].line, 7u);
    EXPECT_EQ(d->samples[1].value[1], 2.0);
}

TEST(SamplesCsv, EveryBadRowIsAnErrorNamingFileLineColumnAndRange) {
    const std::string h = "theta_i,phi_i,theta_o,phi_o,r,g,b,sigma_r,sigma_g,sigma_b,weight,flag\n";
    const std::string ok = "0.1,0,0.2,3,1,1,1,0.1,0.1,0.1,1,0\n";
    struct Case {
        std::string row, expect;
    };
    const Case cases[] = {
        {"0.1,0,0.2,3,1,1\n", ":3: 6 fields, the header has 12"},
        {"0.1,0,0.2,3,1,1,1,0.1,0.1,0.1,1,0,7\n", ":3: 13 fields, the header has 12"},
        {"0.1,0,0.2,3,inf,1,1,0.1,0.1,0.1,1,0\n", ":3:5: r = inf is not finite"},
        {"0.1,0,0.2,3,1,nan,1,0.1,0.1,0.1,1,0\n", ":3:6: g = nan is not finite"},
        {"0.1,0,0.2,3,1e308,1,1,0.1,0.1,0.1,1,0\n", ":3:5: r = 1e+308 outside [-1e9, 1e9] 1/sr"},
        {"0.1,0,0.2,3,1,1,-0.5,0.1,0.1,0.1,1,0\n", ":3:7: b = -0.5 below zero beyond its noise"},
        {"1.5707963267948966,0,0.2,3,1,1,1,0.1,0.1,0.1,1,0\n",
         ":3:1: theta_i = 1.5707963267948966 outside [0, pi/2) (at or below the horizon)"},
        {"0.1,7,0.2,3,1,1,1,0.1,0.1,0.1,1,0\n", ":3:2: phi_i = 7 outside [-2 pi, 2 pi]"},
        {"0.1,0,0.2,3,1,1,1,0.1,-1,0.1,1,0\n", ":3:9: sigma_g = -1 outside [0, 1e9] 1/sr"},
        {"0.1,0,0.2,3,1,1,1,0.1,0.1,0.1,-2,0\n", ":3:11: weight = -2 outside [0, 1e9]"},
        {"0.1,0,0.2,3,1,1,1,0.1,0.1,0.1,1,1.5\n", ":3:12: flag = 1.5 outside [0, 4294967295]"},
        {"0.1,0,0.2,3,1,1,1,0.1,0.1,0.1,1,4294967296\n", ":3:12: flag = 4294967296 outside"},
        {"0.1,0,0.2,3,1,1,1,0.1,0.1,0.1,1,\n", ":3:12: flag = \"\" is not a number"},
        {"0.1,0,0.2,3,1,1,1,0.1,0.1,0.1,1,0x\n", ":3:12: flag = \"0x\" is not a number"},
    };
    int k = 0;
    for (const Case& c : cases) {
        const std::string name = "bad" + std::to_string(k++) + ".csv";
        const std::string p = write(name, h + ok + c.row + ok);
        Expected<Dataset> d = read_dataset_csv(p);
        ASSERT_FALSE(d) << c.row;
        EXPECT_NE(d.error().message.find(p + c.expect), std::string::npos)
            << "expected \"" << c.expect << "\" in: " << d.error().message;
    }
}

TEST(SamplesCsv, AnErrorDeepInALargeFileNamesItsLine) {
    // The error sits in a later chunk of the parallel parse: its line number counts the lines of
    // every earlier chunk, comments included.
    Dataset d = random_dataset(30000);
    const std::string p = temp_path("deep.csv");
    ASSERT_TRUE(write_dataset_csv(p, d));
    {
        std::ofstream out(p, std::ios::app);
        out << "# comment line 30002\n";
        out << "0.1,0,0.2,3,1,1,1,0.1,0.1,0.1,1\n";  // line 30003: 11 fields
    }
    Expected<Dataset> r = read_dataset_csv(p);
    ASSERT_FALSE(r);
    EXPECT_NE(r.error().message.find(p + ":30003: 11 fields, the header has 12"), std::string::npos)
        << r.error().message;
}

TEST(SamplesCsv, HeaderProblemsAreErrors) {
    struct Case {
        std::string text, expect;
    };
    const Case cases[] = {
        {"", "empty file"},
        {"theta_i,phi_i,theta_o,phi_o,r,g\n", ":1: header lacks the required column \"b\""},
        {"theta_i,phi_i,theta_o,phi_o,r,g,b,x\n", ":1: unknown column \"x\""},
        {"theta_i,phi_i,theta_o,phi_o,r,g,b,r\n", ":1: column \"r\" appears twice"},
        {"theta_i,phi_i,theta_o,phi_o,r,g,b,sigma_r\n", "sigma_r, sigma_g and sigma_b"},
    };
    int k = 0;
    for (const Case& c : cases) {
        const std::string p = write("head" + std::to_string(k++) + ".csv", c.text);
        Expected<Dataset> d = load_samples(p);
        ASSERT_FALSE(d);
        EXPECT_NE(d.error().message.find(c.expect), std::string::npos) << d.error().message;
    }
    Expected<Dataset> missing = read_dataset_csv(temp_path("none.csv"));
    ASSERT_FALSE(missing);
    EXPECT_NE(missing.error().message.find("cannot open"), std::string::npos);
}

TEST(SamplesCsv, KeepGoingListsEachRefusedRowWithItsLineAndReason) {
    const std::string text =
        "theta_i,phi_i,theta_o,phi_o,r,g,b\n"
        "0.1,0,0.2,3,0.5,0.5,0.5\n"      // line 2: kept
        "# a comment\n"                  // line 3
        "1.7,0,0.2,3,0.5,0.5,0.5\n"      // line 4: degrees? below the horizon
        "0.1,0,0.2,3,nan,0.5,0.5\n"      // line 5: not finite
        "0.1,0,0.2,3,0.5,abc,0.5\n"      // line 6: not a number
        "0.1,0,0.2,3,0.5,0.5\n"          // line 7: 6 fields
        "0.2,1,0.3,-3,0.25,0.5,0.75\n";  // line 8: kept
    const std::string p = write("keep.csv", text);
    // Strict (the default): the first bad row refuses the file.
    Expected<Dataset> strict = read_dataset_csv(p);
    ASSERT_FALSE(strict);
    EXPECT_NE(strict.error().message.find(p + ":4:1: theta_i = 1.7"), std::string::npos)
        << strict.error().message;
    DatasetReadOptions o;
    o.keep_going = true;
    Expected<Dataset> d = read_dataset_csv(p, o);
    ASSERT_TRUE(d) << d.error().message;
    ASSERT_EQ(d->samples.size(), 2u);
    EXPECT_EQ(d->samples[0].line, 2u);
    EXPECT_EQ(d->samples[1].line, 8u);
    EXPECT_TRUE((d->samples[1].value == Rgbd(0.25, 0.5, 0.75)).all());
    ASSERT_EQ(d->rejected.size(), 4u);
    const std::size_t lines[] = {4, 5, 6, 7};
    const char* reasons[] = {"theta_i = 1.7 outside [0, pi/2)",
                             "r = nan is not finite",
                             "g = \"abc\" is not a number",
                             "6 fields, the header has 7"};
    for (std::size_t k = 0; k < 4; ++k) {
        EXPECT_EQ(d->rejected[k].line, lines[k]);
        EXPECT_EQ(d->rejected[k].reason.rfind(reasons[k], 0), 0u) << d->rejected[k].reason;
    }
    // The same through load_samples; the header stays strict either way.
    Expected<Dataset> l = load_samples(p, o);
    ASSERT_TRUE(l);
    EXPECT_EQ(l->rejected.size(), 4u);
    const std::string bad_head = write("keep_head.csv", "theta_i,phi_i,theta_o,phi_o,r,g,x\n");
    EXPECT_FALSE(read_dataset_csv(bad_head, o));
}

TEST(SamplesCsv, KeepGoingAcrossParallelChunksKeepsFileOrderAndItsLimit) {
    // Every 1000th row of a file parsed in several chunks has a negative theta_i.
    const Dataset d = random_dataset(40000);
    const std::string p = temp_path("keep_big.csv");
    ASSERT_TRUE(write_dataset_csv(p, d));
    std::string text;
    {
        std::ifstream in(p, std::ios::binary);
        text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    // Sample i is on line i + 2.
    std::string out;
    std::size_t line = 1, start = 0;
    std::vector<std::size_t> bad;
    while (start < text.size()) {
        const std::size_t nl = text.find('\n', start);
        std::string row = text.substr(start, nl - start);
        if (line >= 2 && (line - 2) % 1000 == 999) {
            row = "-" + row;
            bad.push_back(line);
        }
        out += row + "\n";
        start = nl + 1;
        ++line;
    }
    std::ofstream(p, std::ios::binary | std::ios::trunc) << out;
    DatasetReadOptions o;
    o.keep_going = true;
    Expected<Dataset> r = read_dataset_csv(p, o);
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(r->samples.size(), 40000u - bad.size());
    ASSERT_EQ(r->rejected.size(), bad.size());
    for (std::size_t k = 0; k < bad.size(); ++k) {
        EXPECT_EQ(r->rejected[k].line, bad[k]);
        EXPECT_EQ(r->rejected[k].reason.rfind("theta_i = -", 0), 0u) << r->rejected[k].reason;
    }
    // One more refused row than allowed: an error naming the row past the limit and the first.
    o.max_rejected = bad.size() - 1;
    Expected<Dataset> over = read_dataset_csv(p, o);
    ASSERT_FALSE(over);
    EXPECT_NE(over.error().message.find(p + ":" + std::to_string(bad.back()) + ": theta_i = -"),
              std::string::npos)
        << over.error().message;
    EXPECT_NE(over.error().message.find("(more than " + std::to_string(bad.size() - 1) +
                                        " rows refused; the first at line " +
                                        std::to_string(bad.front()) + ")"),
              std::string::npos)
        << over.error().message;
}

TEST(SamplesCsv, ExposurePathColumnsRoundTripAndOldFilesStillRead) {
    // A fly scan's rows: swept samples with their exposure's start and end, a standing one among
    // them (its path starts and ends at its own angles and reads back as no path).
    Dataset d = random_dataset(50);
    d.has_path = true;
    for (std::size_t i = 0; i < d.samples.size(); ++i) {
        Sample& s = d.samples[i];
        if (i % 5 == 0) {
            continue;
        }
        s.has_path = true;
        s.path_start = {s.theta_i, s.phi_i, std::max(0.0, s.theta_o - 0.1), s.phi_o};
        s.path_end = {s.theta_i, s.phi_i, std::min(1.55, s.theta_o + 0.1), s.phi_o};
    }
    const std::string p = temp_path("fly.csv");
    ASSERT_TRUE(write_dataset_csv(p, d));
    auto r = read_dataset_csv(p);
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_TRUE(r->has_path);
    ASSERT_EQ(r->samples.size(), d.samples.size());
    for (std::size_t i = 0; i < d.samples.size(); ++i) {
        EXPECT_EQ(r->samples[i].has_path, d.samples[i].has_path) << i;
        if (d.samples[i].has_path) {
            EXPECT_EQ(r->samples[i].path_start, d.samples[i].path_start) << i;
            EXPECT_EQ(r->samples[i].path_end, d.samples[i].path_end) << i;
        }
        EXPECT_EQ(r->samples[i].theta_o, d.samples[i].theta_o) << i;
    }
    // A file of before the columns reads as standing exposures.
    const std::string old =
        write("old.csv", "theta_i,phi_i,theta_o,phi_o,r,g,b\n0.1,0,0.2,3,1,1,1\n");
    auto o = read_dataset_csv(old);
    ASSERT_TRUE(o) << o.error().message;
    EXPECT_FALSE(o->has_path);
    EXPECT_FALSE(o->samples[0].has_path);
    // The eight come together, and a path angle below the horizon names its column and line.
    const std::string some = write(
        "some.csv", "theta_i,phi_i,theta_o,phi_o,r,g,b,theta_i_start\n0.1,0,0.2,3,1,1,1,0.1\n");
    auto s = read_dataset_csv(some);
    ASSERT_FALSE(s);
    EXPECT_NE(s.error().message.find("all eight"), std::string::npos) << s.error().message;
    const std::string below = write("below.csv",
                                    "theta_i,phi_i,theta_o,phi_o,r,g,b,theta_i_start,phi_i_start,"
                                    "theta_o_start,phi_o_start,theta_i_end,phi_i_end,theta_o_end,"
                                    "phi_o_end\n0.1,0,0.2,3,1,1,1,0.1,0,0.1,3,0.1,0,1.7,3\n");
    auto b = read_dataset_csv(below);
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find(":2:14: theta_o_end = 1.7"), std::string::npos)
        << b.error().message;
}

}  // namespace
}  // namespace gonio::brdf
