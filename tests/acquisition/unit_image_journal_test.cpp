// The image-mode frame journal: records read back as written, a record cut at any byte is cut
// off (and the journal appends after the good ones), a damaged record with good ones after it is
// an error, and a table rebuilt from per-frame bin summaries equals the table fed sample by
// sample.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "gonio/acquisition/image/image_journal.h"

namespace gonio::acquisition {
namespace {

std::string journal_path(const std::string& name) {
    return (std::filesystem::temp_directory_path() /
            ("gonio_image_journal_" + name + "_" + std::to_string(::getpid())))
        .string();
}

std::string journal_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void write_all(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

ImageJournalSetup make_setup() {
    ImageJournalSetup s;
    s.layout = coarse_layout(6);
    s.detector_arm_rad = 0.25;
    s.calibration = {1.5, 2.5, 3.5};
    s.sphere.centre = brdf::Vec3d(0.001, -0.002, 0.003);
    s.sphere.radius_m = 0.02;
    s.sphere.silhouette = {100.5, 99.25, 80.125};
    s.sphere.rms_residual_px = 0.03;
    s.sphere.contour_points = 420;
    s.reference_sphere = s.sphere;
    s.reference_sphere.silhouette.r = 79.5;
    s.captures = 17;
    s.exposure_time_s = 0.75;
    return s;
}

ImageJournalFrame make_frame(std::uint32_t seed, const TableLayout& layout) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.01f, 2.0f);
    ImageJournalFrame f;
    f.light_arm_rad = 0.1 * seed;
    f.exposures = {1, 2, 3};
    f.counts.on_sphere = 1000 + seed;
    f.counts.used = 900;
    f.counts.shadow = 50;
    f.coverage_after = 0.01 * seed;
    f.bracketed = seed % 2 == 1;
    f.captures = 7;
    f.exposure_time_s = 0.125;
    for (std::uint32_t b = seed; b < layout.size(); b += 97) {
        BinAggregate a;
        a.bin = b;
        a.count = 1 + b % 5;
        for (int c = 0; c < 3; ++c) {
            a.mean[c] = u(rng);
            a.m2[c] = u(rng);
            a.model_var[c] = u(rng);
            a.position[c] = u(rng);
        }
        f.bins.push_back(a);
    }
    return f;
}

void expect_same(const ImageJournalFrame& a, const ImageJournalFrame& b) {
    EXPECT_EQ(encode_frame(a), encode_frame(b));
    EXPECT_EQ(a.light_arm_rad, b.light_arm_rad);
    EXPECT_EQ(a.counts.used, b.counts.used);
    ASSERT_EQ(a.bins.size(), b.bins.size());
    for (std::size_t i = 0; i < a.bins.size(); ++i) {
        EXPECT_EQ(a.bins[i].bin, b.bins[i].bin);
        EXPECT_EQ(a.bins[i].count, b.bins[i].count);
        EXPECT_EQ(a.bins[i].mean, b.bins[i].mean);
    }
}

TEST(ImageJournal, RecordsReadBackAsWritten) {
    const std::string path = journal_path("roundtrip");
    std::filesystem::remove(path);
    const ImageJournalSetup setup = make_setup();
    std::vector<ImageJournalFrame> frames;
    {
        auto j = ImageJournal::open(path);
        ASSERT_TRUE(j) << j.error().message;
        EXPECT_FALSE(j->setup());
        ASSERT_TRUE(j->append_setup(setup));
        for (std::uint32_t k = 1; k <= 3; ++k) {
            frames.push_back(make_frame(k, setup.layout));
            ASSERT_TRUE(j->append_frame(frames.back()));
        }
    }
    auto j = ImageJournal::open(path);
    ASSERT_TRUE(j) << j.error().message;
    EXPECT_FALSE(j->torn_tail());
    ASSERT_TRUE(j->setup());
    EXPECT_EQ(encode_setup(*j->setup()), encode_setup(setup));
    EXPECT_EQ(j->setup()->layout.n_theta_h, 15);
    EXPECT_EQ(j->setup()->calibration[2], 3.5);
    EXPECT_EQ(j->setup()->sphere.contour_points, 420);
    ASSERT_EQ(j->frames().size(), 3u);
    for (std::size_t k = 0; k < 3; ++k) {
        expect_same(j->frames()[k], frames[k]);
    }
    std::filesystem::remove(path);
}

TEST(ImageJournal, AppendedFramesAreOnDiskNotInMemory) {
    const std::string path = journal_path("held");
    std::filesystem::remove(path);
    const ImageJournalSetup setup = make_setup();
    const ImageJournalFrame f1 = make_frame(1, setup.layout);
    const ImageJournalFrame f2 = make_frame(2, setup.layout);
    {
        auto j = ImageJournal::open(path);
        ASSERT_TRUE(j) << j.error().message;
        ASSERT_TRUE(j->append_setup(setup));
        ASSERT_TRUE(j->append_frame(f1));
        // A campaign holds its table: the journal keeps no second copy of a frame's bins.
        EXPECT_TRUE(j->frames().empty());
    }
    auto j = ImageJournal::open(path);
    ASSERT_TRUE(j) << j.error().message;
    ASSERT_EQ(j->frames().size(), 1u);
    expect_same(j->frames()[0], f1);
    // Merged by the campaign, then released; appending goes on after them.
    j->release_frames();
    EXPECT_TRUE(j->frames().empty());
    EXPECT_EQ(j->frames().capacity(), 0u);
    ASSERT_TRUE(j->append_frame(f2));
    auto again = ImageJournal::open(path);
    ASSERT_TRUE(again) << again.error().message;
    ASSERT_EQ(again->frames().size(), 2u);
    expect_same(again->frames()[1], f2);
    std::filesystem::remove(path);
}

TEST(ImageJournal, RecordCutAtAnyByteIsDroppedAndAppendingContinues) {
    const std::string path = journal_path("torn");
    std::filesystem::remove(path);
    const ImageJournalSetup setup = make_setup();
    const ImageJournalFrame f1 = make_frame(1, setup.layout);
    const ImageJournalFrame f2 = make_frame(2, setup.layout);
    const std::string good = encode_setup(setup) + encode_frame(f1);
    const std::string last = encode_frame(f2);
    // Every cut of the last record (header and payload), and a crash that left zeros behind it.
    std::vector<std::string> damaged;
    for (std::size_t cut = 1; cut < last.size(); cut += (cut < 40 ? 1 : 37)) {
        damaged.push_back(good + last.substr(0, cut));
    }
    std::string flipped = good + last;
    flipped[flipped.size() - 3] ^= 0x10;
    damaged.push_back(flipped);
    damaged.push_back(good + std::string(64, '\0'));
    for (const std::string& bytes : damaged) {
        write_all(path, bytes);
        auto j = ImageJournal::open(path);
        ASSERT_TRUE(j) << j.error().message << " at " << bytes.size() << " bytes";
        EXPECT_TRUE(j->torn_tail()) << bytes.size() << " bytes";
        ASSERT_EQ(j->frames().size(), 1u);
        expect_same(j->frames()[0], f1);
        // The damaged tail is gone: the next frame follows the good records.
        ASSERT_TRUE(j->append_frame(f2));
        EXPECT_EQ(journal_text(path), good + last);
    }
    std::filesystem::remove(path);
}

TEST(ImageJournal, ZoomedFramesKeepTheirPlacementThroughATornTail) {
    const std::string path = journal_path("zoomed");
    std::filesystem::remove(path);
    const ImageJournalSetup setup = make_setup();
    const ImageJournalFrame wide = make_frame(1, setup.layout);
    ImageJournalFrame zoomed = make_frame(2, setup.layout);
    zoomed.placement = 3;
    zoomed.magnification = 8;
    zoomed.offset_m = {0.0148, -0.00025};
    ImageJournalFrame later = make_frame(3, setup.layout);
    later.placement = 1;
    later.magnification = 12.5;
    // A zoomed frame is a record of its own type, longer by its placement.
    EXPECT_EQ(encode_frame(zoomed).size(), encode_frame(make_frame(2, setup.layout)).size() + 28);
    const std::string good = encode_setup(setup) + encode_frame(wide) + encode_frame(zoomed);
    const std::string last = encode_frame(later);
    for (std::size_t cut = 1; cut < last.size(); cut += (cut < 60 ? 1 : 53)) {
        write_all(path, good + last.substr(0, cut));
        auto j = ImageJournal::open(path);
        ASSERT_TRUE(j) << j.error().message << " cut at " << cut;
        EXPECT_TRUE(j->torn_tail());
        ASSERT_EQ(j->frames().size(), 2u);
        EXPECT_EQ(j->frames()[0].placement, 0);
        EXPECT_EQ(j->frames()[1].placement, 3);
        EXPECT_EQ(j->frames()[1].magnification, 8);
        EXPECT_EQ(j->frames()[1].offset_m, zoomed.offset_m);
        expect_same(j->frames()[1], zoomed);
        ASSERT_TRUE(j->append_frame(later));
        EXPECT_EQ(journal_text(path), good + last);
    }
    auto j = ImageJournal::open(path);
    ASSERT_TRUE(j) << j.error().message;
    ASSERT_EQ(j->frames().size(), 3u);
    EXPECT_EQ(j->frames()[2].placement, 1);
    EXPECT_EQ(j->frames()[2].magnification, 12.5);
    // A placement that is no magnification is refused, naming it.
    ImageJournalFrame bad = zoomed;
    bad.magnification = -2;
    write_all(path, encode_setup(setup) + encode_frame(bad) + encode_frame(wide));
    auto b = ImageJournal::open(path);
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("magnification"), std::string::npos) << b.error().message;
    std::filesystem::remove(path);
}

TEST(ImageJournal, DamagedRecordWithGoodOnesAfterItIsCorruption) {
    const std::string path = journal_path("corrupt");
    const ImageJournalSetup setup = make_setup();
    const std::string f1 = encode_frame(make_frame(1, setup.layout));
    std::string bytes = encode_setup(setup) + f1 + encode_frame(make_frame(2, setup.layout));
    bytes[encode_setup(setup).size() + f1.size() / 2] ^= 0x01;
    write_all(path, bytes);
    auto j = ImageJournal::open(path);
    ASSERT_FALSE(j);
    EXPECT_NE(j.error().message.find("record 2"), std::string::npos) << j.error().message;
    EXPECT_NE(j.error().message.find("corrupt"), std::string::npos) << j.error().message;
    // Nothing was cut from a corrupt journal.
    EXPECT_EQ(journal_text(path), bytes);
    std::filesystem::remove(path);
}

TEST(ImageJournal, FrameBeforeSetupAndBinOutsideTheTableAreRefused) {
    const std::string path = journal_path("order");
    const ImageJournalSetup setup = make_setup();
    ImageJournalFrame f = make_frame(1, setup.layout);
    write_all(path, encode_frame(f) + encode_frame(f));
    auto a = ImageJournal::open(path);
    ASSERT_FALSE(a);
    EXPECT_NE(a.error().message.find("before the set-up"), std::string::npos);
    f.bins.back().bin = static_cast<std::uint32_t>(setup.layout.size());
    write_all(path, encode_setup(setup) + encode_frame(f) + encode_frame(f));
    auto b = ImageJournal::open(path);
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("outside the table"), std::string::npos) << b.error().message;
    std::filesystem::remove(path);
}

TEST(FrameBins, MergedSummariesEqualTheTableFedSampleBySample) {
    const TableLayout layout = coarse_layout(6);
    BinnedTable direct(layout);
    BinnedTable merged(layout);
    std::mt19937_64 rng(2718);
    std::uniform_real_distribution<double> u(0, 1);
    std::uint64_t total = 0;
    for (int frame = 0; frame < 5; ++frame) {
        FrameBins fb(layout);
        for (int i = 0; i < 4000; ++i) {
            // Directions in the upper hemisphere, concentrated so that bins get many samples.
            const double ti = 0.2 + 0.3 * u(rng);
            const double to = 0.2 + 0.3 * u(rng);
            const double dp = 2.0 + 0.3 * u(rng);
            const brdf::Vec3d wi(std::sin(ti), 0, std::cos(ti));
            const brdf::Vec3d wo(
                std::sin(to) * std::cos(dp), std::sin(to) * std::sin(dp), std::cos(to));
            const brdf::Rgbd v(0.5 + u(rng), 1 + u(rng), 2 * u(rng));
            const brdf::Rgbd var(1e-3 * u(rng), 2e-3, 3e-3 * u(rng));
            direct.add(wi, wo, v, var);
            fb.add(wi, wo, v, var);
        }
        total += fb.samples();
        for (const BinAggregate& a : fb.aggregates()) {
            merged.merge(a);
        }
    }
    EXPECT_EQ(merged.total_samples(), total);
    EXPECT_EQ(direct.total_samples(), total);
    std::size_t compared = 0;
    for (std::size_t b = 0; b < layout.size(); ++b) {
        ASSERT_EQ(merged.count(b), direct.count(b)) << "bin " << b;
        if (direct.count(b) < 2) {
            continue;
        }
        ++compared;
        for (int c = 0; c < 3; ++c) {
            // Summaries are stored in single precision.
            EXPECT_NEAR(merged.mean(b)[c], direct.mean(b)[c], 1e-6 * std::abs(direct.mean(b)[c]));
            EXPECT_NEAR(merged.sample_variance(b)[c],
                        direct.sample_variance(b)[c],
                        1e-4 * direct.sample_variance(b)[c] + 1e-12);
            EXPECT_NEAR(merged.model_standard_error(b)[c],
                        direct.model_standard_error(b)[c],
                        1e-5 * direct.model_standard_error(b)[c]);
        }
        EXPECT_NEAR(merged.mean_position(b).theta_h, direct.mean_position(b).theta_h, 1e-6);
        EXPECT_NEAR(merged.mean_position(b).phi_d, direct.mean_position(b).phi_d, 1e-5);
    }
    EXPECT_GT(compared, 50u);
}

}  // namespace
}  // namespace gonio::acquisition

namespace gonio::acquisition {
namespace {

ImageJournalSetup make_aniso_setup() {
    ImageJournalSetup s = make_setup();
    s.anisotropic = true;
    s.aniso_layout = {6, 8, 4, 6};
    return s;
}

ImageJournalFrame make_aniso_frame(std::uint32_t seed, const AnisoLayout& layout) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.01f, 2.0f);
    ImageJournalFrame f = make_frame(seed, coarse_layout(6));
    f.bins.clear();
    f.anisotropic = true;
    f.spin_rad = -0.75 + 0.25 * seed;
    f.counts.pole = 11 + seed;
    for (std::uint32_t b = seed; b < layout.size(); b += 13) {
        AnisoBinAggregate a;
        a.bin = b;
        a.count = 1 + b % 4;
        for (auto* arr :
             {&a.mean, &a.m2, &a.model_var, &a.wi, &a.wo, &a.rep_wi, &a.rep_wo, &a.rep_value}) {
            for (float& v : *arr) {
                v = u(rng);
            }
        }
        f.aniso_bins.push_back(a);
    }
    return f;
}

TEST(ImageJournal, AnisotropicRecordsKeepTheSpinOfEachFrame) {
    const std::string path = journal_path("aniso");
    std::filesystem::remove(path);
    const ImageJournalSetup setup = make_aniso_setup();
    std::vector<ImageJournalFrame> frames;
    {
        auto j = ImageJournal::open(path);
        ASSERT_TRUE(j) << j.error().message;
        ASSERT_TRUE(j->append_setup(setup));
        for (std::uint32_t k = 1; k <= 4; ++k) {
            frames.push_back(make_aniso_frame(k, setup.aniso_layout));
            ASSERT_TRUE(j->append_frame(frames.back()));
        }
    }
    // A cut inside the last record: the first three frames stay, with their spins.
    const std::string bytes = journal_text(path);
    write_all(path, bytes.substr(0, bytes.size() - 9));
    auto j = ImageJournal::open(path);
    ASSERT_TRUE(j) << j.error().message;
    EXPECT_TRUE(j->torn_tail());
    ASSERT_TRUE(j->setup());
    EXPECT_TRUE(j->setup()->anisotropic);
    EXPECT_EQ(j->setup()->aniso_layout.describe(), setup.aniso_layout.describe());
    EXPECT_EQ(encode_setup(*j->setup()), encode_setup(setup));
    ASSERT_EQ(j->frames().size(), 3u);
    for (std::size_t k = 0; k < 3; ++k) {
        const ImageJournalFrame& f = j->frames()[k];
        EXPECT_TRUE(f.anisotropic);
        EXPECT_EQ(f.spin_rad, frames[k].spin_rad) << "frame " << k;
        EXPECT_EQ(f.light_arm_rad, frames[k].light_arm_rad);
        EXPECT_EQ(f.counts.pole, frames[k].counts.pole);
        ASSERT_EQ(f.aniso_bins.size(), frames[k].aniso_bins.size());
        EXPECT_EQ(f.aniso_bins.back().rep_value, frames[k].aniso_bins.back().rep_value);
        EXPECT_EQ(encode_frame(f), encode_frame(frames[k]));
    }
    // Appending continues after the good records.
    ASSERT_TRUE(j->append_frame(frames[3]));
    EXPECT_EQ(journal_text(path), bytes);
    std::filesystem::remove(path);
}

TEST(ImageJournal, FramesOfTheOtherKindAndBinsOutsideThe4DTableAreRefused) {
    const std::string path = journal_path("aniso_kind");
    const ImageJournalSetup aniso = make_aniso_setup();
    const ImageJournalSetup iso = make_setup();
    write_all(path,
              encode_setup(iso) + encode_frame(make_aniso_frame(1, aniso.aniso_layout)) +
                  encode_frame(make_aniso_frame(2, aniso.aniso_layout)));
    auto a = ImageJournal::open(path);
    ASSERT_FALSE(a);
    EXPECT_NE(a.error().message.find("an anisotropic frame in the journal of an isotropic"),
              std::string::npos)
        << a.error().message;
    write_all(path,
              encode_setup(aniso) + encode_frame(make_frame(1, iso.layout)) +
                  encode_frame(make_frame(2, iso.layout)));
    auto b = ImageJournal::open(path);
    ASSERT_FALSE(b);
    EXPECT_NE(b.error().message.find("an isotropic frame in the journal of an anisotropic"),
              std::string::npos)
        << b.error().message;
    ImageJournalFrame f = make_aniso_frame(1, aniso.aniso_layout);
    f.aniso_bins.back().bin = static_cast<std::uint32_t>(aniso.aniso_layout.size());
    write_all(path, encode_setup(aniso) + encode_frame(f) + encode_frame(f));
    auto c = ImageJournal::open(path);
    ASSERT_FALSE(c);
    EXPECT_NE(c.error().message.find("outside the 4-D table"), std::string::npos)
        << c.error().message;
    std::filesystem::remove(path);
}

}  // namespace
}  // namespace gonio::acquisition
