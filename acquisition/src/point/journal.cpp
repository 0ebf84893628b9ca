#include "gonio/acquisition/point/journal.h"

#include <cinttypes>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>
#include <utility>

#include "gonio/base/strings.h"

namespace gonio::acquisition {

namespace {

const char* type_name(RecordType t) {
    switch (t) {
        case RecordType::kMeasurement:
            return "measurement";
        case RecordType::kWhite:
            return "white";
        case RecordType::kReference:
            return "reference";
        case RecordType::kNote:
            return "note";
        case RecordType::kSweep:
            return "sweep";
    }
    return "?";
}

template <class V>
nlohmann::json arr(const V& v, int n) {
    nlohmann::json a = nlohmann::json::array();
    for (int k = 0; k < n; ++k) {
        a.push_back(v[k]);
    }
    return a;
}

template <class V>
void get_arr(const nlohmann::json& j, const char* key, V* out, int n) {
    const auto& a = j.at(key);
    if (!a.is_array() || static_cast<int>(a.size()) != n) {
        throw std::runtime_error(std::string(key) + ": expected " + std::to_string(n) + " numbers");
    }
    for (int k = 0; k < n; ++k) {
        (*out)[k] = a[k].get<double>();
    }
}

/// Element `k` of the array `a`: a pose of four numbers.
void get_arr(const nlohmann::json& a, std::size_t k, std::array<double, 4>* out) {
    const auto& p = a.at(k);
    if (!p.is_array() || p.size() != 4) {
        throw std::runtime_error("path_deg: each pose has 4 numbers");
    }
    for (int i = 0; i < 4; ++i) {
        (*out)[i] = p[i].get<double>();
    }
}

}  // namespace

std::uint64_t fnv1a64(const std::string& s) {
    std::uint64_t h = 0xcbf29ce484222325ULL;
    for (unsigned char c : s) {
        h ^= c;
        h *= 0x100000001b3ULL;
    }
    return h;
}

std::string encode_record(const JournalRecord& r) {
    nlohmann::json j;
    j["type"] = type_name(r.type);
    j["pass"] = r.pass;
    j["index"] = r.index;
    j["wi"] = arr(r.wi, 3);
    j["wo"] = arr(r.wo, 3);
    j["pose_deg"] = arr(r.pose_deg, 4);
    j["value"] = arr(r.value, 3);
    j["sigma"] = arr(r.sigma, 3);
    j["rate"] = arr(r.rate, 3);
    j["rate_sigma"] = arr(r.rate_sigma, 3);
    j["flags"] = r.flags;
    j["weight"] = r.weight;
    j["exposure_us"] = r.exposure_us;
    j["time_s"] = r.time_s;
    if (!r.text.empty()) {
        j["text"] = r.text;
    }
    if (r.has_path) {
        j["path_deg"] = {arr(r.path_start_deg, 4), arr(r.path_end_deg, 4)};
    }
    if (r.type == RecordType::kSweep) {
        j["speed_deg_per_s"] = r.speed_deg_per_s;
    }
    const std::string body = j.dump();
    char hash[24];
    std::snprintf(hash, sizeof hash, "%016" PRIx64, fnv1a64(body));
    return body + "\t#" + hash + "\n";
}

Expected<JournalRecord> decode_record(const std::string& line) {
    const auto tab = line.rfind("\t#");
    if (tab == std::string::npos || line.size() != tab + 2 + 16) {
        return make_error("no hash at the end of the line");
    }
    const std::string body = line.substr(0, tab);
    char hash[24];
    std::snprintf(hash, sizeof hash, "%016" PRIx64, fnv1a64(body));
    if (line.compare(tab + 2, 16, hash) != 0) {
        return make_error("hash mismatch (line damaged)");
    }
    JournalRecord r;
    try {
        const nlohmann::json j = nlohmann::json::parse(body);
        const std::string t = j.at("type").get<std::string>();
        if (t == "measurement") {
            r.type = RecordType::kMeasurement;
        } else if (t == "white") {
            r.type = RecordType::kWhite;
        } else if (t == "reference") {
            r.type = RecordType::kReference;
        } else if (t == "note") {
            r.type = RecordType::kNote;
        } else if (t == "sweep") {
            r.type = RecordType::kSweep;
        } else {
            return make_error("unknown record type \"" + t + "\"");
        }
        r.pass = j.at("pass").get<int>();
        r.index = j.at("index").get<std::uint32_t>();
        get_arr(j, "wi", &r.wi, 3);
        get_arr(j, "wo", &r.wo, 3);
        get_arr(j, "pose_deg", &r.pose_deg, 4);
        get_arr(j, "value", &r.value, 3);
        get_arr(j, "sigma", &r.sigma, 3);
        get_arr(j, "rate", &r.rate, 3);
        get_arr(j, "rate_sigma", &r.rate_sigma, 3);
        r.flags = j.at("flags").get<std::uint32_t>();
        r.weight = j.at("weight").get<double>();
        r.exposure_us = j.at("exposure_us").get<double>();
        r.time_s = j.at("time_s").get<double>();
        r.text = j.value("text", std::string());
        if (j.contains("path_deg")) {
            const auto& p = j.at("path_deg");
            if (!p.is_array() || p.size() != 2) {
                throw std::runtime_error("path_deg: expected [start pose, end pose]");
            }
            get_arr(p, 0, &r.path_start_deg);
            get_arr(p, 1, &r.path_end_deg);
            r.has_path = true;
        }
        r.speed_deg_per_s = j.value("speed_deg_per_s", 0.0);
    } catch (const std::exception& e) {
        return make_error(gonio::json_error_text(e.what()));
    }
    return r;
}

Expected<Journal> Journal::open(const std::string& path) {
    Journal jn;
    std::size_t line_no = 0;
    auto next = [&](const std::string& content,
                    std::size_t pos) -> Expected<std::optional<std::size_t>> {
        ++line_no;
        const auto nl = content.find('\n', pos);
        if (nl == std::string::npos) {
            // The last write was cut before its newline: never acknowledged.
            return std::optional<std::size_t>();
        }
        auto rec = decode_record(content.substr(pos, nl - pos));
        if (!rec) {
            const bool last = content.find('\n', nl + 1) == std::string::npos;
            if (last && content.find_first_not_of('\0', nl + 1) == std::string::npos) {
                return std::optional<std::size_t>();
            }
            return make_error(path + ":" + std::to_string(line_no) + ": " + rec.error().message +
                              " with good records after it: the journal is corrupt");
        }
        jn.records_.push_back(std::move(*rec));
        return std::optional<std::size_t>(nl + 1);
    };
    auto log = AppendLog::replay(path, next, &jn.torn_tail_);
    if (!log) {
        return tl::unexpected(log.error());
    }
    jn.log_ = std::move(*log);
    return jn;
}

Expected<void> Journal::append(const JournalRecord& r) {
    if (auto w = log_.append(encode_record(r)); !w) {
        return w;
    }
    records_.push_back(r);
    return {};
}

}  // namespace gonio::acquisition
