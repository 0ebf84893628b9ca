#include "gonio/acquisition/image/image_journal.h"

#include <cmath>
#include <cstring>
#include <optional>
#include <utility>

#include "gonio/acquisition/point/journal.h"
#include "gonio/base/check.h"

namespace gonio::acquisition {
namespace {

constexpr char kMagic[4] = {'G', 'I', 'J', '1'};
constexpr std::size_t kHeaderBytes = 4 + 1 + 4 + 8;
constexpr std::uint8_t kTypeSetup = 1;
constexpr std::uint8_t kTypeFrame = 2;
constexpr std::uint8_t kTypeAnisoSetup = 3;
constexpr std::uint8_t kTypeAnisoFrame = 4;
constexpr std::uint8_t kTypePlacedFrame = 5;
constexpr std::size_t kPlacementBytes = 4 + 3 * 8;

/// Little-endian writer.
class Writer {
  public:
    void u8(std::uint8_t v) { out_.push_back(static_cast<char>(v)); }
    void u32(std::uint32_t v) {
        for (int k = 0; k < 4; ++k) {
            out_.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
        }
    }
    void u64(std::uint64_t v) {
        for (int k = 0; k < 8; ++k) {
            out_.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
        }
    }
    void f64(double v) {
        std::uint64_t bits = 0;
        std::memcpy(&bits, &v, sizeof bits);
        u64(bits);
    }
    void f32(float v) {
        std::uint32_t bits = 0;
        std::memcpy(&bits, &v, sizeof bits);
        u32(bits);
    }
    std::string& bytes() { return out_; }

  private:
    std::string out_;
};

/// Little-endian reader over a payload; any read past the end sets failed().
class Reader {
  public:
    explicit Reader(const std::string& s) : s_(s) {}
    bool failed() const { return failed_; }
    bool at_end() const { return pos_ == s_.size(); }
    std::uint64_t uint(int bytes) {
        if (s_.size() - pos_ < static_cast<std::size_t>(bytes)) {
            failed_ = true;
            pos_ = s_.size();
            return 0;
        }
        std::uint64_t v = 0;
        for (int k = 0; k < bytes; ++k) {
            v |= static_cast<std::uint64_t>(static_cast<unsigned char>(s_[pos_ + k])) << (8 * k);
        }
        pos_ += static_cast<std::size_t>(bytes);
        return v;
    }
    std::uint8_t u8() { return static_cast<std::uint8_t>(uint(1)); }
    std::uint32_t u32() { return static_cast<std::uint32_t>(uint(4)); }
    std::uint64_t u64() { return uint(8); }
    double f64() {
        const std::uint64_t bits = u64();
        double v = 0;
        std::memcpy(&v, &bits, sizeof v);
        return v;
    }
    float f32() {
        const std::uint32_t bits = u32();
        float v = 0;
        std::memcpy(&v, &bits, sizeof v);
        return v;
    }
    std::size_t remaining() const { return s_.size() - pos_; }

  private:
    const std::string& s_;
    std::size_t pos_ = 0;
    bool failed_ = false;
};

std::string wrap(std::uint8_t type, const std::string& payload) {
    Writer w;
    for (char c : kMagic) {
        w.u8(static_cast<std::uint8_t>(c));
    }
    w.u8(type);
    w.u32(static_cast<std::uint32_t>(payload.size()));
    w.u64(fnv1a64(payload));
    w.bytes() += payload;
    return std::move(w.bytes());
}

void put_sphere(Writer& w, const SphereGeometry& s) {
    for (int k = 0; k < 3; ++k) {
        w.f64(s.centre[k]);
    }
    w.f64(s.radius_m);
    w.f64(s.silhouette.cx);
    w.f64(s.silhouette.cy);
    w.f64(s.silhouette.r);
    w.f64(s.rms_residual_px);
    w.u32(static_cast<std::uint32_t>(std::max(0, s.contour_points)));
}

SphereGeometry get_sphere(Reader& r) {
    SphereGeometry s;
    for (int k = 0; k < 3; ++k) {
        s.centre[k] = r.f64();
    }
    s.radius_m = r.f64();
    s.silhouette.cx = r.f64();
    s.silhouette.cy = r.f64();
    s.silhouette.r = r.f64();
    s.rms_residual_px = r.f64();
    s.contour_points = static_cast<int>(r.u32());
    return s;
}

bool finite_sphere(const SphereGeometry& s) {
    return s.centre.allFinite() && std::isfinite(s.radius_m) && std::isfinite(s.silhouette.cx) &&
           std::isfinite(s.silhouette.cy) && std::isfinite(s.silhouette.r) &&
           std::isfinite(s.rms_residual_px);
}

constexpr int kCountFields = 8;

std::array<std::uint64_t*, kCountFields> count_fields(PixelCounts& c) {
    return {&c.on_sphere,
            &c.edge,
            &c.grazing_view,
            &c.shadow,
            &c.grazing_light,
            &c.saturated,
            &c.nonfinite,
            &c.used};
}

Expected<ImageJournalSetup> decode_setup(const std::string& payload, bool anisotropic) {
    Reader r(payload);
    ImageJournalSetup s;
    s.layout.n_theta_h = static_cast<int>(r.u32());
    s.layout.n_theta_d = static_cast<int>(r.u32());
    s.layout.n_phi_d = static_cast<int>(r.u32());
    s.detector_arm_rad = r.f64();
    for (double& c : s.calibration) {
        c = r.f64();
    }
    s.sphere = get_sphere(r);
    s.reference_sphere = get_sphere(r);
    s.captures = r.u64();
    s.exposure_time_s = r.f64();
    s.anisotropic = anisotropic;
    if (anisotropic) {
        s.aniso_layout.n_theta_h = static_cast<int>(r.u32());
        s.aniso_layout.n_phi_h = static_cast<int>(r.u32());
        s.aniso_layout.n_theta_d = static_cast<int>(r.u32());
        s.aniso_layout.n_phi_d = static_cast<int>(r.u32());
    }
    if (r.failed() || !r.at_end()) {
        return make_error("set-up record: payload of " + std::to_string(payload.size()) +
                          " bytes does not have the set-up's fields");
    }
    if (s.layout.n_theta_h < 1 || s.layout.n_theta_d < 1 || s.layout.n_phi_d < 1 ||
        s.layout.n_theta_h > 4096 || s.layout.n_theta_d > 4096 || s.layout.n_phi_d > 4096) {
        return make_error("set-up record: table layout " + std::to_string(s.layout.n_theta_h) +
                          "x" + std::to_string(s.layout.n_theta_d) + "x" +
                          std::to_string(s.layout.n_phi_d) + " outside 1..4096 per axis");
    }
    if (anisotropic && !s.aniso_layout.sane()) {
        return make_error("set-up record: 4-D table layout " + s.aniso_layout.describe() +
                          " outside 1..720 per axis");
    }
    if (!std::isfinite(s.detector_arm_rad) || !std::isfinite(s.exposure_time_s) ||
        !finite_sphere(s.sphere) || !finite_sphere(s.reference_sphere) ||
        !(s.calibration[0] > 0 && s.calibration[1] > 0 && s.calibration[2] > 0 &&
          std::isfinite(s.calibration[0]) && std::isfinite(s.calibration[1]) &&
          std::isfinite(s.calibration[2]))) {
        return make_error(
            "set-up record: a non-finite angle, sphere or exposure time, or a calibration "
            "constant not positive and finite");
    }
    return s;
}

Expected<ImageJournalFrame> decode_aniso_frame(const std::string& payload,
                                               const AnisoLayout& layout) {
    Reader r(payload);
    ImageJournalFrame f;
    f.anisotropic = true;
    f.light_arm_rad = r.f64();
    f.spin_rad = r.f64();
    for (int& e : f.exposures) {
        e = static_cast<int>(r.u32());
    }
    for (std::uint64_t* v : count_fields(f.counts)) {
        *v = r.u64();
    }
    f.counts.pole = r.u64();
    f.coverage_after = r.f64();
    f.bracketed = r.u8() != 0;
    f.captures = r.u64();
    f.exposure_time_s = r.f64();
    const std::uint32_t n = r.u32();
    constexpr std::size_t kBinBytes = 4 + 4 + 24 * 4;
    if (r.failed() || r.remaining() != static_cast<std::size_t>(n) * kBinBytes) {
        return make_error("anisotropic frame record: payload of " + std::to_string(payload.size()) +
                          " bytes does not hold its " + std::to_string(n) + " bins");
    }
    if (!std::isfinite(f.light_arm_rad) || !std::isfinite(f.spin_rad) ||
        !std::isfinite(f.coverage_after) || !std::isfinite(f.exposure_time_s)) {
        return make_error(
            "anisotropic frame record: non-finite light position, spin, coverage or exposure "
            "time");
    }
    f.aniso_bins.resize(n);
    for (AnisoBinAggregate& a : f.aniso_bins) {
        a.bin = r.u32();
        a.count = r.u32();
        for (auto* arr :
             {&a.mean, &a.m2, &a.model_var, &a.wi, &a.wo, &a.rep_wi, &a.rep_wo, &a.rep_value}) {
            for (float& v : *arr) {
                v = r.f32();
                if (!std::isfinite(v)) {
                    return make_error("anisotropic frame record: bin " + std::to_string(a.bin) +
                                      " holds a non-finite value");
                }
            }
        }
        if (a.bin >= layout.size()) {
            return make_error("anisotropic frame record: bin " + std::to_string(a.bin) +
                              " outside the 4-D table of " + std::to_string(layout.size()) +
                              " bins");
        }
    }
    return f;
}

Expected<ImageJournalFrame> decode_frame(const std::string& payload, const TableLayout& layout) {
    Reader r(payload);
    ImageJournalFrame f;
    f.light_arm_rad = r.f64();
    for (int& e : f.exposures) {
        e = static_cast<int>(r.u32());
    }
    for (std::uint64_t* v : count_fields(f.counts)) {
        *v = r.u64();
    }
    f.coverage_after = r.f64();
    f.bracketed = r.u8() != 0;
    f.captures = r.u64();
    f.exposure_time_s = r.f64();
    const std::uint32_t n = r.u32();
    constexpr std::size_t kBinBytes = 4 + 4 + 12 * 4;
    if (r.failed() || r.remaining() != static_cast<std::size_t>(n) * kBinBytes) {
        return make_error("frame record: payload of " + std::to_string(payload.size()) +
                          " bytes does not hold its " + std::to_string(n) + " bins");
    }
    if (!std::isfinite(f.light_arm_rad) || !std::isfinite(f.coverage_after) ||
        !std::isfinite(f.exposure_time_s)) {
        return make_error("frame record: non-finite light position, coverage or exposure time");
    }
    f.bins.resize(n);
    for (BinAggregate& a : f.bins) {
        a.bin = r.u32();
        a.count = r.u32();
        for (auto* arr : {&a.mean, &a.m2, &a.model_var, &a.position}) {
            for (float& v : *arr) {
                v = r.f32();
                if (!std::isfinite(v)) {
                    return make_error("frame record: bin " + std::to_string(a.bin) +
                                      " holds a non-finite value");
                }
            }
        }
        if (a.bin >= layout.size()) {
            return make_error("frame record: bin " + std::to_string(a.bin) +
                              " outside the table of " + std::to_string(layout.size()) + " bins");
        }
    }
    return f;
}

/// A type-5 record: the placement, then a type-2 payload.
Expected<ImageJournalFrame> decode_placed_frame(const std::string& payload,
                                                const TableLayout& layout) {
    const std::string head = payload.substr(0, std::min(payload.size(), kPlacementBytes));
    Reader r(head);  // holds a reference: the bytes must outlive it
    const std::uint32_t placement = r.u32();
    const double magnification = r.f64();
    const double ox = r.f64();
    const double oy = r.f64();
    if (r.failed() || !r.at_end()) {
        return make_error("zoomed frame record: payload of " + std::to_string(payload.size()) +
                          " bytes does not hold its placement");
    }
    if (placement < 1 || placement > 1024 || !std::isfinite(magnification) ||
        !(magnification > 0) || !std::isfinite(ox) || !std::isfinite(oy)) {
        return make_error("zoomed frame record: placement " + std::to_string(placement) +
                          " outside 1..1024, or a magnification not positive and finite, or a "
                          "non-finite offset");
    }
    auto f = decode_frame(payload.substr(kPlacementBytes), layout);
    if (!f) {
        return make_error("zoomed " + f.error().message);
    }
    f->placement = static_cast<int>(placement);
    f->magnification = magnification;
    f->offset_m = {ox, oy};
    return f;
}

}  // namespace

std::string encode_setup(const ImageJournalSetup& s) {
    Writer w;
    w.u32(static_cast<std::uint32_t>(s.layout.n_theta_h));
    w.u32(static_cast<std::uint32_t>(s.layout.n_theta_d));
    w.u32(static_cast<std::uint32_t>(s.layout.n_phi_d));
    w.f64(s.detector_arm_rad);
    for (double c : s.calibration) {
        w.f64(c);
    }
    put_sphere(w, s.sphere);
    put_sphere(w, s.reference_sphere);
    w.u64(s.captures);
    w.f64(s.exposure_time_s);
    if (s.anisotropic) {
        const AnisoLayout& a = s.aniso_layout;
        for (int n : {a.n_theta_h, a.n_phi_h, a.n_theta_d, a.n_phi_d}) {
            w.u32(static_cast<std::uint32_t>(std::max(0, n)));
        }
        return wrap(kTypeAnisoSetup, w.bytes());
    }
    return wrap(kTypeSetup, w.bytes());
}

std::string encode_frame(const ImageJournalFrame& f) {
    Writer w;
    const bool placed = !f.anisotropic && f.placement > 0;
    if (placed) {
        w.u32(static_cast<std::uint32_t>(f.placement));
        w.f64(f.magnification);
        w.f64(f.offset_m[0]);
        w.f64(f.offset_m[1]);
    }
    w.f64(f.light_arm_rad);
    if (f.anisotropic) {
        w.f64(f.spin_rad);
    }
    for (int e : f.exposures) {
        w.u32(static_cast<std::uint32_t>(std::max(0, e)));
    }
    PixelCounts c = f.counts;
    for (std::uint64_t* v : count_fields(c)) {
        w.u64(*v);
    }
    if (f.anisotropic) {
        w.u64(c.pole);
        w.f64(f.coverage_after);
        w.u8(f.bracketed ? 1 : 0);
        w.u64(f.captures);
        w.f64(f.exposure_time_s);
        w.u32(static_cast<std::uint32_t>(f.aniso_bins.size()));
        for (const AnisoBinAggregate& a : f.aniso_bins) {
            w.u32(a.bin);
            w.u32(a.count);
            for (const auto* arr :
                 {&a.mean, &a.m2, &a.model_var, &a.wi, &a.wo, &a.rep_wi, &a.rep_wo, &a.rep_value}) {
                for (float v : *arr) {
                    w.f32(v);
                }
            }
        }
        return wrap(kTypeAnisoFrame, w.bytes());
    }
    w.f64(f.coverage_after);
    w.u8(f.bracketed ? 1 : 0);
    w.u64(f.captures);
    w.f64(f.exposure_time_s);
    w.u32(static_cast<std::uint32_t>(f.bins.size()));
    for (const BinAggregate& a : f.bins) {
        w.u32(a.bin);
        w.u32(a.count);
        for (const auto* arr : {&a.mean, &a.m2, &a.model_var, &a.position}) {
            for (float v : *arr) {
                w.f32(v);
            }
        }
    }
    return wrap(placed ? kTypePlacedFrame : kTypeFrame, w.bytes());
}

Expected<ImageJournal> ImageJournal::open(const std::string& path) {
    ImageJournal jn;
    std::size_t record = 0;
    auto next = [&](const std::string& content,
                    std::size_t pos) -> Expected<std::optional<std::size_t>> {
        ++record;
        const std::string where =
            path + ": record " + std::to_string(record) + " at byte " + std::to_string(pos) + ": ";
        if (content.size() - pos < kHeaderBytes) {
            // The last write stopped inside the record header: never acknowledged.
            return std::optional<std::size_t>();
        }
        const std::string head = content.substr(pos, kHeaderBytes);
        Reader hr(head);
        char magic[4];
        for (char& m : magic) {
            m = static_cast<char>(hr.u8());
        }
        const std::uint8_t type = hr.u8();
        const std::uint32_t length = hr.u32();
        const std::uint64_t hash = hr.u64();
        const std::size_t end = pos + kHeaderBytes + length;
        const bool magic_ok = std::memcmp(magic, kMagic, 4) == 0;
        if (magic_ok && end > content.size()) {
            // Cut short inside the payload.
            return std::optional<std::size_t>();
        }
        const std::string payload =
            magic_ok ? content.substr(pos + kHeaderBytes, length) : std::string();
        if (!magic_ok || fnv1a64(payload) != hash) {
            if (!magic_ok ? content.find_first_not_of('\0', pos) == std::string::npos
                          : end == content.size()) {
                // The last record is damaged (or the file ends in zeros after a crash).
                return std::optional<std::size_t>();
            }
            return make_error(where + (magic_ok ? "wrong hash" : "no record header") +
                              " with more data after it: the journal is corrupt");
        }
        if (type == kTypeSetup || type == kTypeAnisoSetup) {
            if (record != 1) {
                return make_error(where + "a second set-up record");
            }
            auto s = decode_setup(payload, type == kTypeAnisoSetup);
            if (!s) {
                return make_error(where + s.error().message);
            }
            jn.setup_ = *s;
        } else if (type == kTypeFrame || type == kTypeAnisoFrame || type == kTypePlacedFrame) {
            if (!jn.setup_) {
                return make_error(where + "a frame before the set-up record");
            }
            const bool aniso = type == kTypeAnisoFrame;
            if (aniso != jn.setup_->anisotropic) {
                return make_error(where + (aniso ? "an anisotropic frame" : "an isotropic frame") +
                                  " in the journal of an " + (aniso ? "isotropic" : "anisotropic") +
                                  " campaign");
            }
            auto f = aniso ? decode_aniso_frame(payload, jn.setup_->aniso_layout)
                     : type == kTypePlacedFrame ? decode_placed_frame(payload, jn.setup_->layout)
                                                : decode_frame(payload, jn.setup_->layout);
            if (!f) {
                return make_error(where + f.error().message);
            }
            jn.frames_.push_back(std::move(*f));
        } else {
            return make_error(where + "unknown record type " + std::to_string(type));
        }
        return std::optional<std::size_t>(end);
    };
    auto log = AppendLog::replay(path, next, &jn.torn_tail_);
    if (!log) {
        return tl::unexpected(log.error());
    }
    jn.log_ = std::move(*log);
    return jn;
}

Expected<void> ImageJournal::append_setup(const ImageJournalSetup& s) {
    GONIO_CHECK_MSG(!setup_ && frames_.empty(), path() << ": set-up after other records");
    if (auto w = log_.append(encode_setup(s)); !w) {
        return w;
    }
    setup_ = s;
    return {};
}

Expected<void> ImageJournal::append_frame(const ImageJournalFrame& f) {
    GONIO_CHECK_MSG(setup_.has_value(), path() << ": frame before the set-up");
    return log_.append(encode_frame(f));
}

}  // namespace gonio::acquisition
