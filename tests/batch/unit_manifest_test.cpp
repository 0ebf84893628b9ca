// Manifests, shards and fit requests (gonio::batch).

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "gonio/batch/fit_request.h"
#include "gonio/batch/manifest.h"

namespace fs = std::filesystem;
using gonio::batch::FitRequest;

namespace {

fs::path fresh_dir() {
    const fs::path dir =
        fs::path(GONIO_BINARY_DIR) / "tests" /
        (std::string("batch_") + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

fs::path write(const fs::path& p, const std::string& text) {
    std::ofstream(p) << text;
    return p;
}

}  // namespace

TEST(Shard, ParsesKOverNAndRejectsOutOfRange) {
    auto s = gonio::batch::parse_shard("3/8");
    ASSERT_TRUE(s) << s.error().message;
    EXPECT_EQ(s->k, 3u);
    EXPECT_EQ(s->n, 8u);
    for (const char* bad : {"8/8", "1/0", "-1/4", "1", "a/b", "1/4/2", "/4", "1/"}) {
        auto b = gonio::batch::parse_shard(bad);
        ASSERT_FALSE(b) << bad;
        EXPECT_NE(b.error().message.find("0 <= K < N"), std::string::npos);
    }
}

TEST(Shard, ShardsPartitionEveryManifestSize) {
    for (std::size_t count = 0; count <= 23; ++count) {
        std::vector<gonio::batch::ManifestEntry> entries(count);
        for (std::size_t i = 0; i < count; ++i) {
            entries[i].index = i;
            entries[i].id = "e" + std::to_string(i);
        }
        for (std::size_t n = 1; n <= 6; ++n) {
            std::multiset<std::size_t> seen;
            std::size_t largest = 0, smallest = count;
            for (std::size_t k = 0; k < n; ++k) {
                const auto shard = gonio::batch::select_shard(entries, {k, n});
                largest = std::max(largest, shard.size());
                smallest = std::min(smallest, shard.size());
                for (const auto& e : shard) {
                    EXPECT_EQ(e.index % n, k);
                    seen.insert(e.index);
                }
            }
            ASSERT_EQ(seen.size(), count) << count << " entries, " << n << " shards";
            EXPECT_EQ(std::set<std::size_t>(seen.begin(), seen.end()).size(), count);
            EXPECT_LE(largest - smallest, 1u);  // balanced within one entry
        }
    }
}

TEST(Manifest, ResolvesPathsDefaultsIdsAndParsesOptions) {
    const fs::path dir = fresh_dir();
    const fs::path m = write(dir / "m.csv",
                             "# comment\n\ninput,model,options,id\n"
                             "a/x.csv,beckmann,residual=cosine; max_samples=500 ;diffuse=no,\n"
                             "/abs/y.binary,tpl.json,,named\n");
    auto entries = gonio::batch::read_manifest(m.string());
    ASSERT_TRUE(entries) << entries.error().message;
    ASSERT_EQ(entries->size(), 2u);
    const auto& e0 = (*entries)[0];
    EXPECT_EQ(e0.id, "x");
    EXPECT_EQ(e0.line, 4u);
    EXPECT_EQ(e0.input, (dir / "a/x.csv").string());
    EXPECT_EQ(e0.request.model, "beckmann");
    EXPECT_EQ(e0.request.residual, "cosine");
    EXPECT_EQ(e0.request.max_samples, 500u);
    EXPECT_FALSE(e0.request.diffuse);
    const auto& e1 = (*entries)[1];
    EXPECT_EQ(e1.id, "named");
    EXPECT_EQ(e1.input, "/abs/y.binary");
    EXPECT_EQ(e1.request.model, (dir / "tpl.json").string());
}

TEST(Manifest, ErrorsNameFileLineAndRule) {
    const fs::path dir = fresh_dir();
    struct Case {
        std::string text;
        std::string expect;
    };
    const Case cases[] = {
        {"input,model,colour\n", "m.csv:1: unknown column \"colour\""},
        {"model,options\n", "m.csv:1: header lacks the column \"input\""},
        {"input,model,options\nx.csv,ggx\n", "m.csv:2: 2 fields, header has 3"},
        {"input,model,options\nx.csv,ggx,starts=0\n",
         "m.csv:2: option starts = 0: outside [1, 1000]"},
        {"input,model,options\nx.csv,ggx,speed=3\n", "m.csv:2: unknown option \"speed\""},
        {"input,model,options\nx.csv,ggxx,\n", "m.csv:2: model:"},
        {"input,model,options\nx.csv,ggx,\ny/x.csv,ggx,\n",
         "m.csv:3: id \"x\" already used on line 2"},
        {"input,model,options,id\nx.csv,ggx,,a/b\n", "m.csv:2: id \"a/b\""},
        {"# only a comment\n", "m.csv: no header line"},
        {"input,model,options\nx.csv,auto,lobes=2\n",
         "m.csv:2: option lobes cannot be combined with model auto"},
    };
    for (const Case& c : cases) {
        const fs::path m = write(dir / "m.csv", c.text);
        auto r = gonio::batch::read_manifest(m.string());
        ASSERT_FALSE(r) << c.text;
        EXPECT_NE(r.error().message.find(c.expect), std::string::npos)
            << r.error().message << " | expected: " << c.expect;
    }
}

TEST(FitRequest, FormattedOptionsReadBackToTheSameRequest) {
    FitRequest r;
    ASSERT_TRUE(gonio::batch::set_options(
        r,
        "model=blinn-phong;fresnel=none;lobes=2;loss=huber;loss_scale=0.25;seed=9;threads=1;"
        "anisotropic=yes;max-iterations=50"));
    FitRequest back;
    ASSERT_TRUE(gonio::batch::set_options(back, gonio::batch::format_options(r)));
    EXPECT_EQ(gonio::batch::format_options(back), gonio::batch::format_options(r));
    EXPECT_EQ(back.lobes, 2);
    EXPECT_EQ(back.loss_scale, 0.25);
    EXPECT_EQ(back.max_iterations, 50);
    EXPECT_TRUE(back.anisotropic);
    auto spec = gonio::batch::make_fit_spec(back);
    ASSERT_TRUE(spec) << spec.error().message;
    EXPECT_EQ(spec->model.lobes.size(), 2u);
    EXPECT_EQ(spec->options.seed, 9u);
    EXPECT_EQ(spec->options.loss, gonio::fitting::LossKind::kHuber);
}

TEST(RunEntry, UnreadableInputIsReportedAndRetriedNotSkipped) {
    const fs::path dir = fresh_dir();
    gonio::batch::ManifestEntry e;
    e.id = "gone";
    e.input = (dir / "missing.csv").string();
    const std::string out = (dir / "out").string();
    const auto o = gonio::batch::run_entry(e, out);
    EXPECT_EQ(o.status, gonio::batch::EntryStatus::kFailed);
    EXPECT_NE(o.message.find("missing.csv"), std::string::npos) << o.message;
    EXPECT_TRUE(fs::exists(gonio::batch::error_path(out, "gone")));
    EXPECT_FALSE(gonio::batch::entry_finished(out, "gone"));
    // The summary row keeps one line and the column count even with commas in the message.
    auto row = gonio::batch::summary_csv_row(
        {"a", "in,put", gonio::batch::EntryStatus::kFailed, "x, y\nz", 0, 0, 0, 0, 0});
    EXPECT_EQ(std::count(row.begin(), row.end(), ','), 8);
    EXPECT_EQ(row.find('\n'), std::string::npos);
}

namespace gonio::batch {
namespace {

TEST(FitRequestContract, AutoAndTemplatesRefuseEveryStructureOptionGivenByName) {
    for (const char* key : {"fresnel", "shadowing", "diffuse", "anisotropic", "lobes"}) {
        const std::string value = std::string(key) == "fresnel"     ? "none"
                                  : std::string(key) == "shadowing" ? "v-groove"
                                  : std::string(key) == "lobes"     ? "2"
                                                                    : "true";
        FitRequest r;
        ASSERT_TRUE(set_option(r, "model", "auto"));
        EXPECT_FALSE(find_conflict(r)) << "nothing given yet";
        ASSERT_TRUE(set_option(r, key, value));
        auto c = find_conflict(r);
        ASSERT_TRUE(c) << key;
        EXPECT_EQ(c->option, key);
        EXPECT_EQ(c->with, "model");
        FitRequest t;
        ASSERT_TRUE(set_option(t, "model", "tmpl.json"));
        ASSERT_TRUE(set_option(t, key, value));
        EXPECT_TRUE(find_conflict(t)) << key;
        FitRequest g;
        ASSERT_TRUE(set_option(g, "model", "beckmann"));
        ASSERT_TRUE(set_option(g, key, value));
        EXPECT_FALSE(find_conflict(g)) << key << " is honoured by a named distribution";
    }
    // Solver options go with auto: the candidates share them.
    FitRequest a;
    ASSERT_TRUE(set_option(a, "model", "auto"));
    ASSERT_TRUE(set_option(a, "residual", "relative"));
    ASSERT_TRUE(set_option(a, "max_samples", "500"));
    EXPECT_FALSE(find_conflict(a));
    auto spec = make_fit_spec(a);
    ASSERT_TRUE(spec) << spec.error().message;
    EXPECT_EQ(spec->options.max_samples, 500u);
    EXPECT_EQ(spec->options.residual, fitting::ResidualForm::kRelative);
}

TEST(FitRequestContract, ManifestAcceptsAuto) {
    const fs::path dir = fresh_dir();
    const fs::path m = write(dir / "m.csv", "input,model,options\nx.csv,auto,residual=relative\n");
    auto r = read_manifest(m.string());
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_TRUE(r->front().request.is_auto());
}

TEST(FitRequestContract, UnknownModelNamesAutoAmongTheChoices) {
    FitRequest r;
    auto s = set_option(r, "model", "ggz");
    ASSERT_FALSE(s);
    EXPECT_NE(s.error().message.find("auto"), std::string::npos) << s.error().message;
}

}  // namespace
}  // namespace gonio::batch
