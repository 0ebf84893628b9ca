// FitRequest: options by name and the fit spec they describe.

#include "gonio/batch/fit_request.h"

#include <cerrno>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "gonio/base/strings.h"
#include "gonio/batch/fit_policy.h"
#include "gonio/fitting/power_iteration.h"

namespace gonio::batch {

namespace {

Expected<bool> parse_bool(const std::string& key, const std::string& v) {
    if (v == "true" || v == "1" || v == "yes") {
        return true;
    }
    if (v == "false" || v == "0" || v == "no") {
        return false;
    }
    return make_error("option " + key + " = \"" + v + "\": expected true/false/1/0/yes/no");
}

Expected<long long> parse_int(const std::string& key,
                              const std::string& v,
                              long long lo,
                              long long hi) {
    char* end = nullptr;
    errno = 0;
    const long long x = std::strtoll(v.c_str(), &end, 10);
    if (v.empty() || end != v.c_str() + v.size() || errno == ERANGE) {
        return make_error("option " + key + " = \"" + v + "\": not an integer");
    }
    if (x < lo || x > hi) {
        return make_error("option " + key + " = " + v + ": outside [" + std::to_string(lo) + ", " +
                          std::to_string(hi) + "]");
    }
    return x;
}

Expected<double> parse_positive(const std::string& key, const std::string& v) {
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(v.c_str(), &end);
    if (v.empty() || end != v.c_str() + v.size() || errno == ERANGE) {
        return make_error("option " + key + " = \"" + v + "\": not a number");
    }
    if (!(x > 0) || x > std::numeric_limits<double>::max()) {
        return make_error("option " + key + " = " + v + ": must be a finite number > 0");
    }
    return x;
}

}  // namespace

std::string default_distribution() {
    return brdf::to_string(fitting::ModelOptions{}.distribution);
}

std::string default_fresnel() {
    const fitting::ModelOptions o;
    const std::string name = brdf::to_string(o.fresnel);
    return o.fresnel == brdf::FresnelType::kSchlick && o.fresnel_rgb ? name + "-rgb" : name;
}

std::string default_shadowing() {
    return brdf::to_string(fitting::ModelOptions{}.shadowing);
}

bool FitRequest::is_template() const {
    return !template_json.empty() || ends_with(model, ".json");
}

bool FitRequest::was_given(const std::string& key) const {
    for (const std::string& k : given) {
        if (k == key) {
            return true;
        }
    }
    return false;
}

std::optional<OptionConflict> find_conflict(const FitRequest& r) {
    if (!r.is_auto() && !r.is_template()) {
        return std::nullopt;
    }
    for (const char* key :
         {"fresnel", "shadowing", "diffuse", "anisotropic", "lobes", "roughness"}) {
        if (r.was_given(key)) {
            return OptionConflict{key,
                                  "model",
                                  r.is_auto() ? "model auto chooses the structure itself"
                                              : "a fit template states the structure itself"};
        }
    }
    return std::nullopt;
}

namespace {

Expected<void> set_option_value(FitRequest& r, const std::string& key, const std::string& v);

}  // namespace

Expected<void> set_option(FitRequest& r, const std::string& key_in, const std::string& value_in) {
    std::string key = trim(key_in);
    for (char& c : key) {
        if (c == '-') {
            c = '_';
        }
    }
    auto s = set_option_value(r, key, trim(value_in));
    if (s && !r.was_given(key)) {
        r.given.push_back(key);
    }
    return s;
}

namespace {

/// A name that fitting's `parse` accepts, kept as written.
template <class Parse>
Expected<void> set_name(const std::string& key,
                        const std::string& v,
                        Parse parse,
                        std::string* out) {
    auto parsed = parse(v);
    if (!parsed) {
        return make_error("option " + key + ": " + parsed.error().message);
    }
    *out = v;
    return {};
}

/// A whole number in [lo, hi].
template <class T>
Expected<void> set_integer(
    const std::string& key, const std::string& v, long long lo, long long hi, T* out) {
    auto n = parse_int(key, v, lo, hi);
    if (!n) {
        return tl::unexpected(n.error());
    }
    *out = static_cast<T>(*n);
    return {};
}

Expected<void> set_flag(const std::string& key, const std::string& v, bool* out) {
    auto b = parse_bool(key, v);
    if (!b) {
        return tl::unexpected(b.error());
    }
    *out = *b;
    return {};
}

/// "model": a distribution, auto or a *.json fit template.
Expected<void> set_model(FitRequest& r, const std::string& v) {
    if (v.empty()) {
        return make_error("option model is empty");
    }
    if (v != kAutoModel && !ends_with(v, ".json")) {
        auto d = fitting::parse_distribution(v);
        if (!d) {
            return make_error("option model: " + d.error().message +
                              ", auto or a *.json fit "
                              "template");
        }
    }
    r.model = v;
    return {};
}

Expected<void> set_option_value(FitRequest& r, const std::string& key, const std::string& v) {
    constexpr long long kIntMax = std::numeric_limits<int>::max();
    constexpr long long kLongMax = std::numeric_limits<long long>::max();
    if (key == "model") {
        return set_model(r, v);
    }
    if (key == "fresnel") {
        return set_name(key, v, fitting::parse_fresnel, &r.fresnel);
    }
    if (key == "shadowing") {
        return set_name(key, v, fitting::parse_shadowing, &r.shadowing);
    }
    if (key == "diffuse") {
        return set_flag(key, v, &r.diffuse);
    }
    if (key == "anisotropic") {
        return set_flag(key, v, &r.anisotropic);
    }
    if (key == "lobes") {
        return set_integer(key, v, 0, 4, &r.lobes);
    }
    if (key == "roughness") {
        return set_name(key, v, fitting::parse_roughness, &r.roughness);
    }
    if (key == "residual") {
        return set_name(key, v, fitting::parse_residual, &r.residual);
    }
    if (key == "loss") {
        return set_name(key, v, fitting::parse_loss, &r.loss);
    }
    if (key == "loss_scale") {
        auto x = parse_positive(key, v);
        if (!x) {
            return tl::unexpected(x.error());
        }
        r.loss_scale = *x;
        return {};
    }
    if (key == "max_samples") {
        return set_integer(key, v, 0, kLongMax, &r.max_samples);
    }
    if (key == "starts") {
        return set_integer(key, v, 1, 1000, &r.starts);
    }
    if (key == "seed") {
        return set_integer(key, v, 0, kLongMax, &r.seed);
    }
    if (key == "max_iterations") {
        return set_integer(key, v, 1, kIntMax, &r.max_iterations);
    }
    if (key == "threads") {
        return set_integer(key, v, 0, 4096, &r.threads);
    }
    return make_error("unknown option \"" + key +
                      "\" (known: model, fresnel, shadowing, diffuse, anisotropic, lobes, "
                      "roughness, residual, loss, loss_scale, max_samples, starts, seed, "
                      "max_iterations, threads)");
}

}  // namespace

Expected<void> set_options(FitRequest& r, const std::string& options) {
    std::stringstream ss(options);
    std::string item;
    while (std::getline(ss, item, ';')) {
        item = trim(item);
        if (item.empty()) {
            continue;
        }
        const auto eq = item.find('=');
        if (eq == std::string::npos) {
            return make_error("option \"" + item + "\": expected key=value");
        }
        auto s = set_option(r, item.substr(0, eq), item.substr(eq + 1));
        if (!s) {
            return s;
        }
    }
    return {};
}

std::string format_options(const FitRequest& r) {
    std::ostringstream o;
    // The shortest precision that reads back to the same double (0.1, not 0.10000000000000001).
    int digits = 15;
    for (; digits < 17; ++digits) {
        std::ostringstream t;
        t.precision(digits);
        t << r.loss_scale;
        if (std::strtod(t.str().c_str(), nullptr) == r.loss_scale) {
            break;
        }
    }
    o.precision(digits);
    o << "model=" << r.model << ";fresnel=" << r.fresnel << ";shadowing=" << r.shadowing
      << ";diffuse=" << (r.diffuse ? "true" : "false")
      << ";anisotropic=" << (r.anisotropic ? "true" : "false") << ";lobes=" << r.lobes
      << ";roughness=" << r.roughness << ";residual=" << r.residual << ";loss=" << r.loss
      << ";loss_scale=" << r.loss_scale << ";max_samples=" << r.max_samples
      << ";starts=" << r.starts << ";seed=" << r.seed << ";max_iterations=" << r.max_iterations
      << ";threads=" << r.threads;
    return o.str();
}

Expected<fitting::FitSpec> make_fit_spec(const FitRequest& r) {
    Expected<fitting::FitSpec> spec = make_error("");
    if (!r.template_json.empty()) {
        spec = fitting::parse_fit_template(r.template_json, "<template>");
    } else if (ends_with(r.model, ".json")) {
        spec = fitting::load_fit_template(r.model);
    } else {
        auto dist = fitting::parse_distribution(r.is_auto() ? default_distribution() : r.model);
        if (!dist) {
            return tl::unexpected(dist.error());
        }
        auto fres = fitting::parse_fresnel(r.fresnel);
        if (!fres) {
            return tl::unexpected(fres.error());
        }
        auto shad = fitting::parse_shadowing(r.shadowing);
        if (!shad) {
            return tl::unexpected(shad.error());
        }
        auto rough = fitting::parse_roughness(r.roughness);
        if (!rough) {
            return tl::unexpected(rough.error());
        }
        fitting::ModelOptions mo;
        mo.rgb_roughness = *rough;
        mo.distribution = *dist;
        mo.fresnel = fres->first;
        mo.fresnel_rgb = fres->second;
        mo.shadowing = *shad;
        mo.diffuse = r.diffuse;
        mo.anisotropic = r.anisotropic;
        mo.lobes = r.lobes;
        spec = fitting::make_fit_spec(mo);
    }
    if (!spec) {
        return spec;
    }
    auto residual = fitting::parse_residual(r.residual);
    if (!residual) {
        return tl::unexpected(residual.error());
    }
    auto loss = fitting::parse_loss(r.loss);
    if (!loss) {
        return tl::unexpected(loss.error());
    }
    spec->options.residual = *residual;
    spec->options.loss = *loss;
    spec->options.loss_scale = r.loss_scale;
    spec->options.max_samples = r.max_samples;
    spec->options.starts = r.starts;
    spec->options.seed = r.seed;
    spec->options.max_iterations = r.max_iterations;
    spec->options.num_threads = r.threads;
    return spec;
}

Expected<FitRun> run_fit(const brdf::Dataset& data, const FitRequest& r) {
    if (auto c = find_conflict(r)) {
        return make_error("option " + c->option + " cannot be combined with model " +
                          (r.is_auto() ? std::string(kAutoModel) : r.model) + ": " + c->rule);
    }
    auto spec = make_fit_spec(r);
    if (!spec) {
        return tl::unexpected(spec.error());
    }
    FitRun run;
    if (r.is_auto()) {
        auto chosen = fitting::fit_auto(data, fitting::auto_candidates(spec->options));
        if (!chosen) {
            return tl::unexpected(chosen.error());
        }
        run.result = std::move(chosen->best);
        // Every family was ranked: what is left to suggest is the measurement itself.
        run.result.goodness.suggestion =
            run.result.goodness.verdict == fitting::Verdict::kRepresents
                ? std::string()
                : table_alternative(data, data.source, run.result.goodness.verdict);
        run.ranking = std::move(chosen->ranking);
        run.chosen = std::move(chosen->chosen);
        run.criterion = std::move(chosen->criterion);
        return run;
    }
    auto result = fitting::fit_any(data, *spec);
    if (!result) {
        return tl::unexpected(result.error());
    }
    run.result = std::move(*result);
    return run;
}

}  // namespace gonio::batch
