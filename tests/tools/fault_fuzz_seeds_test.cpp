// The fuzz seeds that readers once accepted silently (out-of-range numbers, unknown keys, wrong
// types, reversed ranges, NaN, nesting bombs) must stay refused, with a message: each is read here
// by the same reader its fuzz target drives, and a reader that starts accepting one turns this red.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/point/campaign.h"
#include "gonio/acquisition/shared/rig_config.h"
#include "gonio/brdf/dataset.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/model_json.h"
#include "gonio/fitting/spec.h"

namespace gonio {
namespace {

std::string corpus(const std::string& target, const std::string& name) {
    return std::string(GONIO_SOURCE_DIR) + "/fuzz/corpus/" + target + "/" + name;
}

std::string text_of(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

/// The reader's error message, or "" when it accepted the file. A seed missing from the corpus
/// fails the test (a reader's refusal of a file that is not there would prove nothing).
std::string refusal(const std::string& target, const std::string& name) {
    const std::string path = corpus(target, name);
    if (!std::filesystem::is_regular_file(path)) {
        ADD_FAILURE() << target << "/" << name << ": no such seed in fuzz/corpus";
        return "missing seed";
    }
    auto why = [](const auto& r) { return r ? std::string() : r.error().message; };
    if (target == "campaign_json") {
        return why(acquisition::parse_campaign_spec(text_of(path), "campaign.json"));
    }
    if (target == "rig_json") {
        return why(acquisition::parse_rig_config(text_of(path), "rig.json"));
    }
    if (target == "scene") {
        return why(acquisition::read_scene(path));
    }
    if (target == "fit_template") {
        return why(fitting::parse_fit_template(text_of(path), "template.json"));
    }
    if (target == "model_json") {
        return why(brdf::parse_model_json(text_of(path), "model.json"));
    }
    if (target == "csv") {
        return why(brdf::read_dataset_csv(path));
    }
    if (target == "merl") {
        return why(brdf::read_table_file(path));
    }
    return "unknown target " + target;
}

struct Seed {
    const char* target;
    const char* name;
};

const Seed kRefused[] = {
    {"campaign_json", "deep_nesting.json"},
    {"campaign_json", "junk_plan.json"},
    {"campaign_json", "n_theta_1e20.json"},
    {"campaign_json", "plan_not_object.json"},
    {"campaign_json", "unknown_key.json"},
    {"campaign_json", "value_type_error.json"},
    {"campaign_json", "nested_arrays.json"},
    {"rig_json", "axes_object.json"},
    {"rig_json", "deep_nesting.json"},
    {"rig_json", "limits_string.json"},
    {"rig_json", "retries_1e308.json"},
    {"rig_json", "unit_1e20.json"},
    {"rig_json", "unknown_capture_key.json"},
    {"rig_json", "unknown_key.json"},
    {"scene", "deep_nesting.json"},
    {"scene", "ranges_nan.json"},
    {"scene", "ranges_reversed.json"},
    {"scene", "unknown_key.json"},
    {"scene", "zero_vector.json"},
    {"fit_template", "bounds_inf.json"},
    {"fit_template", "bounds_reversed.json"},
    {"fit_template", "deep_nesting.json"},
    {"fit_template", "no_model.json"},
    {"fit_template", "unknown_key.json"},
    {"fit_template", "unknown_path.json"},
    {"fit_template", "model_diffuse_1e308.json"},
    {"model_json", "deep_nesting.json"},
    {"model_json", "diffuse_1e308.json"},
    {"model_json", "huge_number.json"},
    {"model_json", "seventeen_lobes.json"},
    {"model_json", "syntax_error.json"},
    {"model_json", "unknown_key.json"},
    {"model_json", "wrong_type.json"},
    {"csv", "below_horizon.csv"},
    {"csv", "binary.csv"},
    {"csv", "empty.csv"},
    {"csv", "huge_values.csv"},
    {"csv", "nan_inf.csv"},
    {"csv", "wrong_field_count.csv"},
    {"merl", "empty.binary"},
    {"merl", "huge_dims.gtab"},
    {"merl", "inf.gtab"},
    {"merl", "nan.gtab"},
    {"merl", "negative_dims.gtab"},
    {"merl", "short_header.binary"},
    {"merl", "trailing.gtab"},
    {"merl", "truncated.binary"},
    {"merl", "truncated.gtab"},
    {"merl", "wrong_dims.binary"},
    {"merl", "zero_dims.gtab"},
};

TEST(FuzzSeeds, OnceAcceptedSilentlyAreRefusedWithAMessage) {
    for (const Seed& s : kRefused) {
        const std::string why = refusal(s.target, s.name);
        EXPECT_FALSE(why.empty()) << s.target << "/" << s.name << " was accepted";
    }
}

TEST(FuzzSeeds, TheValidSeedsStillRead) {
    for (const Seed& s : {Seed{"campaign_json", "valid.json"},
                          Seed{"model_json", "plastic-ggx.json"},
                          Seed{"csv", "valid.csv"},
                          Seed{"merl", "valid_2x2x4.gtab"},
                          Seed{"rig_json", "sim4.json"}}) {
        EXPECT_EQ(refusal(s.target, s.name), "") << s.target << "/" << s.name;
    }
}

}  // namespace
}  // namespace gonio
