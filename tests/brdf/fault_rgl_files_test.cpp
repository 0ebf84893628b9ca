// Broken RGL tensor files are refused with a message naming the file and the field; spectral
// files and files whose azimuths are neither form are refused naming what is supported. The inputs
// are the fuzz target's seed corpus (fuzz/corpus/rgl_bsdf), small hand-made files.

#include <gtest/gtest.h>

#include <string>

#include "gonio/brdf/rgl_bsdf.h"
#include "gonio/brdf/tensor_file.h"

namespace {

std::string corpus(const std::string& name) {
    return std::string(GONIO_SOURCE_DIR) + "/fuzz/corpus/rgl_bsdf/" + name;
}

// The error of reading a corpus file; empty when it was accepted.
std::string refusal(const std::string& name) {
    auto b = gonio::brdf::read_rgl_bsdf(corpus(name));
    return b ? std::string() : b.error().message;
}

void expect_refused(const std::string& name, const std::string& field, const std::string& rule) {
    const std::string m = refusal(name);
    ASSERT_FALSE(m.empty()) << name << " was accepted";
    EXPECT_NE(m.find(corpus(name)), std::string::npos) << m;
    EXPECT_NE(m.find(field), std::string::npos) << m;
    EXPECT_NE(m.find(rule), std::string::npos) << m;
}

TEST(RglFiles, HandMadeValidFilesAreRead) {
    for (const char* name :
         {"valid_minimal.bsdf", "valid_three_theta.bsdf", "valid_anisotropic.bsdf"}) {
        auto b = gonio::brdf::read_rgl_bsdf(corpus(name));
        ASSERT_TRUE(b) << b.error().message;
        EXPECT_EQ(b->description(), "test");
        EXPECT_GT(b->nodes().size(), 0u);
    }
}

TEST(RglFiles, TruncatedFilesAreRefused) {
    expect_refused("empty.bsdf", "0 bytes", "truncated");
    expect_refused("truncated_header.bsdf", "field", "truncated");
    expect_refused("truncated_data.bsdf", "field \"", "past the end of the file");
}

TEST(RglFiles, WrongMagicAndVersionAreRefused) {
    expect_refused("wrong_magic.bsdf", "tensor_file", "not a tensor file");
    expect_refused("version_2.bsdf", "version 2.0", "only 1.0");
}

TEST(RglFiles, UnknownDataTypeIsRefused) {
    expect_refused("unknown_dtype.bsdf", "field \"theta_i\"", "unknown data type 12");
}

TEST(RglFiles, ShapesThatDisagreeAreRefused) {
    expect_refused("shapes_disagree.bsdf", "rgb [1, 2, 3, 3, 2]", "shapes disagree");
}

TEST(RglFiles, OffsetsPastTheEndOrIntoTheHeaderAreRefused) {
    expect_refused("offset_past_end.bsdf", "field \"rgb\"", "past the end of the file");
    expect_refused("overlaps_header.bsdf", "field \"rgb\"", "overlaps the header");
}

TEST(RglFiles, HugeSizesAreRefusedWithoutAllocating) {
    expect_refused("huge_size.bsdf", "field \"vndf\"", "larger than the file");
    expect_refused("overflow_size.bsdf", "field \"vndf\"", "larger than the file");
}

TEST(RglFiles, BadValuesAndMissingFieldsAreRefused) {
    expect_refused("theta_decreasing.bsdf", "field \"theta_i\"", "increase strictly");
    expect_refused("sigma_nan.bsdf", "field \"sigma\"", "finite");
    expect_refused("vndf_no_mass.bsdf", "field \"vndf\"", "no mass");
    expect_refused("duplicate_field.bsdf", "field \"phi_i\"", "appears twice");
    expect_refused("no_jacobian.bsdf", "field \"jacobian\"", "missing");
}

TEST(RglFiles, AnisotropicAndSpectralFilesNameWhatIsSupported) {
    // Two phi_i nodes: neither an isotropic file (one) nor an anisotropic one (a full turn).
    expect_refused(
        "anisotropic.bsdf", "field \"phi_i\" has 2 nodes", "at least 3 over a full turn");
    expect_refused("spectral.bsdf", "spectral", "gonio reads RGB files");
}

TEST(RglFiles, TensorCodecRoundTripsFieldsByteForByte) {
    using namespace gonio::brdf;
    TensorFile f;
    f.fields.push_back(TensorField::uint8("a", {3}, {1, 2, 3}));
    f.fields.push_back(TensorField::float32("b", {2, 2}, {0.5f, -1.0f, 3.25f, 1e-30f}));
    const std::string bytes = encode_tensor_file(f);
    EXPECT_EQ(bytes.compare(0, 12, std::string("tensor_file\0", 12)), 0);
    auto back =
        parse_tensor_file(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), "mem");
    ASSERT_TRUE(back) << back.error().message;
    ASSERT_EQ(back->fields.size(), 2u);
    EXPECT_EQ(back->fields[0].data, f.fields[0].data);
    EXPECT_EQ(back->fields[1].as_float32(), (std::vector<float>{0.5f, -1.0f, 3.25f, 1e-30f}));
    EXPECT_EQ(back->fields[1].offset % 8, 0u);
    EXPECT_EQ(encode_tensor_file(*back), bytes);
}

}  // namespace
