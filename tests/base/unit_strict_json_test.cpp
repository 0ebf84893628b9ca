// The strict JSON reader: each rule refuses with a message naming the file, the key path, the value
// and the rule, and a document that keeps every rule reads to the values it holds.

#include <gtest/gtest.h>

#include <string>

#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"

namespace gonio {
namespace {

struct Plan {
    std::string kind;
    int n_theta = 7;
    double theta_max_deg = 75;
    bool adaptive = false;
};

/// A small schema in the style of campaign.json: {"name", "plan": {"kind", "n_theta",
/// "theta_max_deg"}, "adaptive"}.
Expected<Plan> read_plan(const std::string& text) {
    return read_strict_json("campaign.json", [&] {
        const nlohmann::json j = parse_json_checked(text, "campaign.json");
        JsonObject top(j, "");
        Plan p;
        p.adaptive = top.boolean("adaptive", p.adaptive);
        if (top.has("plan")) {
            JsonObject plan(top.raw("plan"), "plan");
            p.kind = plan.string("kind", "uniform", 16);
            p.n_theta = plan.integer("n_theta", p.n_theta, 2, 500);
            p.theta_max_deg = plan.number("theta_max_deg", p.theta_max_deg, 1, 89, "deg");
            plan.finish();
        }
        top.finish();
        return p;
    });
}

std::string error_of(const std::string& text) {
    const Expected<Plan> p = read_plan(text);
    return p ? std::string("(read)") : p.error().message;
}

TEST(StrictJson, ReadsTheValuesAndTheDefaults) {
    const Expected<Plan> p =
        read_plan(R"({"plan": {"kind": "half-diff", "n_theta": 12, "theta_max_deg": 60.5},
                      "adaptive": true})");
    ASSERT_TRUE(p) << p.error().message;
    EXPECT_EQ(p->kind, "half-diff");
    EXPECT_EQ(p->n_theta, 12);
    EXPECT_EQ(p->theta_max_deg, 60.5);
    EXPECT_TRUE(p->adaptive);
    const Expected<Plan> d = read_plan(R"({"plan": {}})");
    ASSERT_TRUE(d) << d.error().message;
    EXPECT_EQ(d->kind, "uniform");
    EXPECT_EQ(d->n_theta, 7);
    EXPECT_EQ(d->theta_max_deg, 75);
    EXPECT_FALSE(d->adaptive);
}

TEST(StrictJson, EachRuleNamesTheFileTheKeyPathAndTheRule) {
    const struct {
        const char* text;
        const char* message;
    } cases[] = {
        {R"({"plan": {"n_theta": "7"}})",
         "campaign.json: plan.n_theta: expected a whole number, got string"},
        {R"({"plan": {"n_theta": 2.5}})",
         "campaign.json: plan.n_theta = 2.5: must be a whole number in [2, 500]"},
        // Checked as a double before the cast: never wrapped to a small int.
        {R"({"plan": {"n_theta": 1e20}})",
         "campaign.json: plan.n_theta = 1e+20: must be a whole number in [2, 500]"},
        {R"({"plan": {"theta_max_deg": 90}})",
         "campaign.json: plan.theta_max_deg = 90: must be in [1, 89] deg"},
        {R"({"plan": {"theta_max_deg": null}})",
         "campaign.json: plan.theta_max_deg: expected a number, got null"},
        {R"({"plan": {"kind": "uniform-grid-of-many-points"}})",
         "campaign.json: plan.kind: 27 characters, at most 16 allowed"},
        {R"({"plan": {"kind": "a\nb"}})",
         "campaign.json: plan.kind: control characters (line breaks, ...) not allowed"},
        {R"({"adaptive": 1})", "campaign.json: adaptive: expected true or false, got number"},
        {R"({"plan": [1, 2]})", "campaign.json: plan: expected an object, got array"},
        {R"([1, 2])", "campaign.json: top level: expected an object, got array"},
        // Unknown keys, with the keys the reader knows in the order it names them.
        {R"({"plan": {"n_thetta": 9}})",
         "campaign.json: plan.n_thetta: unknown key (allowed here: kind, n_theta, "
         "theta_max_deg)"},
        {R"({"plann": {}})", "campaign.json: plann: unknown key (allowed here: adaptive, plan)"},
        {R"({"plan": {}, )", "campaign.json: parse error at line 1, column 14"},
    };
    for (const auto& c : cases) {
        const std::string e = error_of(c.text);
        EXPECT_EQ(e.rfind(c.message, 0), 0u) << "input " << c.text << "\n  got " << e;
    }
}

TEST(StrictJson, AnUnknownKeyIsQuotedShortAndEscaped) {
    const std::string key(5000, 'k');
    const std::string e = error_of("{\"plan\": {\"" + key + "\": 1, \"n_theta\": 3}}");
    EXPECT_EQ(e.rfind("campaign.json: plan.kkkk", 0), 0u) << e;
    EXPECT_LT(e.size(), 200u) << e;
    const std::string c = error_of(R"({"pl\u0001an": 1})");
    EXPECT_NE(c.find("pl\\x01an: unknown key"), std::string::npos) << c;
}

TEST(StrictJson, SizeAndDepthAreCheckedBeforeParsing) {
    const std::string deep =
        std::string(kMaxJsonDepth + 1, '[') + std::string(kMaxJsonDepth + 1, ']');
    const std::string e = error_of(deep);
    EXPECT_EQ(e.rfind("campaign.json:1: objects and arrays nested deeper than", 0), 0u) << e;
}

TEST(StrictJson, KeysCheckedAgainstAListAndMembersRequired) {
    const nlohmann::json j = nlohmann::json::parse(R"({"type": "schlick", "f0": 0.04})");
    auto keys = [&](std::vector<std::string> allowed) {
        return read_strict_json("model.json",
                                [&] { check_json_keys(j, "lobes[0].fresnel", allowed); });
    };
    EXPECT_TRUE(keys({"type", "f0"}));
    const Expected<void> k = keys({"type"});
    ASSERT_FALSE(k);
    EXPECT_EQ(k.error().message,
              "model.json: lobes[0].fresnel.f0: unknown key (allowed here: type)");
    const Expected<double> m = read_strict_json("model.json", [&] {
        return json_number_at(json_member(j, "lobes[0].fresnel", "eta"), "lobes[0].fresnel.eta");
    });
    ASSERT_FALSE(m);
    EXPECT_EQ(m.error().message, "model.json: lobes[0].fresnel: missing key \"eta\"");
    const Expected<double> f0 = read_strict_json(
        "model.json", [&] { return json_number_at(j.at("f0"), "lobes[0].fresnel.f0"); });
    ASSERT_TRUE(f0);
    EXPECT_EQ(*f0, 0.04);
    const Expected<std::string> s = read_strict_json(
        "model.json", [&] { return json_string_at(j.at("f0"), "lobes[0].fresnel.f0"); });
    ASSERT_FALSE(s);
    EXPECT_EQ(s.error().message, "model.json: lobes[0].fresnel.f0: expected a string, got number");
}

TEST(StrictJson, AllowedKeysAreNotUnknown) {
    const nlohmann::json j = nlohmann::json::parse(R"({"a": 1, "note": "x"})");
    const Expected<int> r = read_strict_json("x.json", [&] {
        JsonObject o(j, "");
        o.allow({"note"});
        const int a = o.integer("a", 0, 0, 9);
        o.finish();
        return a;
    });
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(*r, 1);
    const Expected<int> missing = read_strict_json("x.json", [&] {
        JsonObject o(j, "");
        return o.raw("b").get<int>();
    });
    ASSERT_FALSE(missing);
    EXPECT_EQ(missing.error().message, "x.json: top level: missing key \"b\"");
}

}  // namespace
}  // namespace gonio
