// GenICam cameras through Aravis: feature access by SFNC names with the fallbacks real cameras
// need, a buffer pool sized from PayloadSize, software-triggered or single-frame capture, and
// frames decoded into counts with their id and timestamp.

#include "gonio/devices/aravis_camera.h"

#include <arpa/inet.h>
#include <arv.h>
#include <netdb.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <utility>

#include "gonio/devices/packed_pixels.h"

namespace gonio::devices {

namespace {

/// GigE Vision Control Protocol port (GigE Vision 2.0, section 7).
constexpr std::uint16_t kGvcpPort = 3956;
/// Buffers of a line-triggered stream: the frames of a sweep queue while the host is busy.
constexpr int kLineStreamBuffers = 64;

/// Takes a GError: its message, and frees it.
std::string take_message(GError* error) {
    if (error == nullptr) {
        return "unknown error";
    }
    std::string m = error->message != nullptr ? error->message : "unknown error";
    g_error_free(error);
    return m;
}

std::string fmt_number(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

const char* buffer_status_name(ArvBufferStatus s) {
    switch (s) {
        case ARV_BUFFER_STATUS_UNKNOWN:
            return "unknown";
        case ARV_BUFFER_STATUS_SUCCESS:
            return "success";
        case ARV_BUFFER_STATUS_CLEARED:
            return "cleared";
        case ARV_BUFFER_STATUS_TIMEOUT:
            return "timeout before all packets arrived";
        case ARV_BUFFER_STATUS_MISSING_PACKETS:
            return "missing packets";
        case ARV_BUFFER_STATUS_WRONG_PACKET_ID:
            return "wrong packet id";
        case ARV_BUFFER_STATUS_SIZE_MISMATCH:
            return "image larger than the buffer";
        case ARV_BUFFER_STATUS_FILLING:
            return "still filling";
        case ARV_BUFFER_STATUS_ABORTED:
            return "aborted";
    }
    return "unknown";
}

/// The local IPv4 address the kernel would send from to reach `remote` (a connected UDP socket
/// sends nothing), so that a camera can be opened without a discovery broadcast.
Expected<std::string> local_address_towards(const std::string& remote) {
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    if (fd < 0) {
        return make_error(std::string("socket: ") + std::strerror(errno));
    }
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(kGvcpPort);
    ::inet_pton(AF_INET, remote.c_str(), &to.sin_addr);
    if (::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
        const std::string why = std::strerror(errno);
        ::close(fd);
        return make_error("no route to " + remote + ": " + why);
    }
    sockaddr_in from{};
    socklen_t len = sizeof from;
    if (::getsockname(fd, reinterpret_cast<sockaddr*>(&from), &len) != 0) {
        const std::string why = std::strerror(errno);
        ::close(fd);
        return make_error("getsockname: " + why);
    }
    ::close(fd);
    char buf[INET_ADDRSTRLEN];
    ::inet_ntop(AF_INET, &from.sin_addr, buf, sizeof buf);
    return std::string(buf);
}

/// HOST (a name or dotted IPv4 address) as a dotted IPv4 address.
Expected<std::string> resolve_ipv4(const std::string& host) {
    addrinfo hints{};
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_DGRAM;
    addrinfo* res = nullptr;
    if (const int rc = ::getaddrinfo(host.c_str(), nullptr, &hints, &res); rc != 0) {
        return make_error("cannot resolve '" + host + "': " + ::gai_strerror(rc));
    }
    char buf[INET_ADDRSTRLEN];
    ::inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(res->ai_addr)->sin_addr, buf, sizeof buf);
    ::freeaddrinfo(res);
    return std::string(buf);
}

enum class TriggerMethod {
    kUnknown,      ///< not decided yet
    kSoftware,     ///< TriggerMode On, TriggerSource Software, one TriggerSoftware per frame
    kSingleFrame,  ///< AcquisitionMode SingleFrame, one AcquisitionStart per frame
};

}  // namespace

struct AravisCamera::Impl {
    ArvCamera* camera = nullptr;
    ArvDevice* device = nullptr;  // owned by camera
    ArvStream* stream = nullptr;
    gulong control_lost_handler = 0;
    std::atomic<bool> control_lost{false};
    AravisOptions options;
    std::string name;
    std::string address;
    AravisStreamStats stats;
    AravisStreamStats stream_base;  // counters of streams already destroyed
    TriggerMethod trigger = TriggerMethod::kUnknown;
    bool acquiring = false;  // AcquisitionStart sent, not yet stopped
    bool streaming = false;  // start_stream() running
    bool auto_modes_off = false;
    std::size_t payload = 0;
    int buffers = 0;  ///< Buffers the stream was given.
    double exposure_us = 0;
    double gain = 1;
    bool exposure_known = false;
    double black_level = 0;  // counts, from BlackLevel when the camera states it in DN

    ~Impl() {
        if (acquiring) {
            (void)stop_acquisition();
        }
        drop_stream();
        if (device != nullptr && control_lost_handler != 0) {
            g_signal_handler_disconnect(device, control_lost_handler);
        }
        if (camera != nullptr) {
            g_object_unref(camera);
        }
    }

    static void on_control_lost(ArvDevice* /*device*/, gpointer self) {
        static_cast<Impl*>(self)->control_lost = true;
    }

    Error err(const std::string& what) const { return Error{name + ": " + what}; }

    // ---- feature access ---------------------------------------------------------------------

    ArvGcNode* node(const char* feature) const { return arv_device_get_feature(device, feature); }

    /// True when the feature exists in the XML, is implemented and is available now.
    bool has(const char* feature) const {
        ArvGcNode* n = node(feature);
        if (n == nullptr || !ARV_IS_GC_FEATURE_NODE(n)) {
            return false;
        }
        GError* e = nullptr;
        const gboolean impl = arv_gc_feature_node_is_implemented(ARV_GC_FEATURE_NODE(n), &e);
        if (e != nullptr) {
            g_error_free(e);
            return false;
        }
        const gboolean avail = arv_gc_feature_node_is_available(ARV_GC_FEATURE_NODE(n), &e);
        if (e != nullptr) {
            g_error_free(e);
            return false;
        }
        return impl && avail;
    }

    bool has_entry(const char* feature, const char* entry) const {
        if (!has(feature)) {
            return false;
        }
        GError* e = nullptr;
        const gboolean ok = arv_device_is_enumeration_entry_available(device, feature, entry, &e);
        if (e != nullptr) {
            g_error_free(e);
            return false;
        }
        return ok;
    }

    /// A feature's range as the camera's GenICam description gives it. A minimum above the
    /// maximum (or a bound that is not a number) is the camera's fault: the error names the
    /// feature and both bounds.
    Expected<void> check_range(const std::string& feature, double lo, double hi) const {
        if (lo <= hi) {
            return {};
        }
        return tl::unexpected(err("the camera's GenICam description gives " + feature +
                                  " the range [" + fmt_number(lo) + ", " + fmt_number(hi) +
                                  "], minimum above maximum: a fault of the camera's description, "
                                  "not of the request"));
    }

    /// The bounds of an integer feature, checked.
    Expected<std::pair<std::int64_t, std::int64_t>> int_range(const char* feature) const {
        GError* e = nullptr;
        gint64 lo = 0, hi = 0;
        arv_device_get_integer_feature_bounds(device, feature, &lo, &hi, &e);
        if (e != nullptr) {
            return tl::unexpected(err("range of " + std::string(feature) + ": " + take_message(e)));
        }
        if (auto r = check_range(feature, static_cast<double>(lo), static_cast<double>(hi)); !r) {
            return tl::unexpected(r.error());
        }
        return std::make_pair(static_cast<std::int64_t>(lo), static_cast<std::int64_t>(hi));
    }

    Expected<void> require(const char* feature, const std::string& why) const {
        if (!has(feature)) {
            return tl::unexpected(
                err("the camera has no feature " + std::string(feature) + " (needed " + why + ")"));
        }
        return {};
    }

    Expected<void> set_enum(const char* feature, const char* value) {
        if (!has_entry(feature, value)) {
            return tl::unexpected(err(std::string(feature) + " has no entry '" + value + "'"));
        }
        GError* e = nullptr;
        arv_device_set_string_feature_value(device, feature, value, &e);
        if (e != nullptr) {
            return tl::unexpected(
                err("setting " + std::string(feature) + " = " + value + ": " + take_message(e)));
        }
        return {};
    }

    Expected<void> set_int(const char* feature, std::int64_t value) {
        GError* e = nullptr;
        arv_device_set_integer_feature_value(device, feature, value, &e);
        if (e != nullptr) {
            return tl::unexpected(err("setting " + std::string(feature) + " = " +
                                      std::to_string(value) + ": " + take_message(e)));
        }
        return {};
    }

    Expected<std::int64_t> get_int(const char* feature) {
        GError* e = nullptr;
        const gint64 v = arv_device_get_integer_feature_value(device, feature, &e);
        if (e != nullptr) {
            return tl::unexpected(err("reading " + std::string(feature) + ": " + take_message(e)));
        }
        return static_cast<std::int64_t>(v);
    }

    Expected<double> get_float(const char* feature) {
        GError* e = nullptr;
        const double v = arv_device_get_float_feature_value(device, feature, &e);
        if (e != nullptr) {
            return tl::unexpected(err("reading " + std::string(feature) + ": " + take_message(e)));
        }
        return v;
    }

    Expected<void> set_float(const char* feature, double value) {
        GError* e = nullptr;
        arv_device_set_float_feature_value(device, feature, value, &e);
        if (e != nullptr) {
            return tl::unexpected(err("setting " + std::string(feature) + " = " +
                                      fmt_number(value) + ": " + take_message(e)));
        }
        return {};
    }

    Expected<void> execute(const char* feature) {
        if (auto r = require(feature, "to run the command"); !r) {
            return r;
        }
        GError* e = nullptr;
        arv_device_execute_command(device, feature, &e);
        if (e != nullptr) {
            return tl::unexpected(
                err("executing " + std::string(feature) + ": " + take_message(e)));
        }
        return {};
    }

    std::string string_or_empty(const char* feature) {
        if (!has(feature)) {
            return {};
        }
        GError* e = nullptr;
        const char* v = arv_device_get_string_feature_value(device, feature, &e);
        if (e != nullptr) {
            g_error_free(e);
            return {};
        }
        return v != nullptr ? v : "";
    }

    /// Turns ExposureAuto and GainAuto off once: a radiometric capture sets both itself.
    void auto_off() {
        if (auto_modes_off) {
            return;
        }
        auto_modes_off = true;
        for (const char* f : {"ExposureAuto", "GainAuto"}) {
            if (has_entry(f, "Off")) {
                (void)set_enum(f, "Off");
            }
        }
    }

    // ---- exposure and gain ------------------------------------------------------------------

    Expected<ExposureFeature> exposure_feature() {
        ExposureFeature f;
        for (const char* name : {"ExposureTime", "ExposureTimeAbs"}) {
            ArvGcNode* n = node(name);
            if (n == nullptr || !ARV_IS_GC_FLOAT(n) || !has(name)) {
                continue;
            }
            f.name = name;
            const char* unit = arv_gc_float_get_unit(ARV_GC_FLOAT(n));
            f.unit = unit != nullptr ? unit : "";
            if (f.unit.empty() || f.unit == "us" || f.unit == "\xC2\xB5s") {
                f.us_per_unit = 1;
            } else if (f.unit == "ms") {
                f.us_per_unit = 1e3;
            } else if (f.unit == "s") {
                f.us_per_unit = 1e6;
            } else if (f.unit == "ns") {
                f.us_per_unit = 1e-3;
            } else {
                return tl::unexpected(err(std::string(name) + " has unit '" + f.unit +
                                          "', not a time unit gonio knows (s, ms, us, ns)"));
            }
            GError* e = nullptr;
            const double lo = arv_gc_float_get_min(ARV_GC_FLOAT(n), &e);
            const double hi = e == nullptr ? arv_gc_float_get_max(ARV_GC_FLOAT(n), &e) : 0;
            if (e != nullptr) {
                return tl::unexpected(
                    err("range of " + std::string(name) + ": " + take_message(e)));
            }
            if (auto r = check_range(name, lo, hi); !r) {
                return tl::unexpected(r.error());
            }
            f.min_us = lo * f.us_per_unit;
            f.max_us = hi * f.us_per_unit;
            return f;
        }
        if (has("ExposureTimeRaw")) {
            if (!has("ExposureTimeBaseAbs")) {
                return tl::unexpected(
                    err("the camera has ExposureTimeRaw but no ExposureTimeBaseAbs, so the unit "
                        "of ExposureTimeRaw is unknown (and no ExposureTime or ExposureTimeAbs)"));
            }
            auto base = get_float("ExposureTimeBaseAbs");
            if (!base) {
                return tl::unexpected(base.error());
            }
            if (!(*base > 0) || !std::isfinite(*base)) {
                return tl::unexpected(err("ExposureTimeBaseAbs = " + fmt_number(*base) +
                                          " us is not a positive time base"));
            }
            f.name = "ExposureTimeRaw";
            f.unit = fmt_number(*base) + " us (ExposureTimeBaseAbs)";
            f.us_per_unit = *base;
            auto range = int_range("ExposureTimeRaw");
            if (!range) {
                return tl::unexpected(range.error());
            }
            f.min_us = static_cast<double>(range->first) * f.us_per_unit;
            f.max_us = static_cast<double>(range->second) * f.us_per_unit;
            return f;
        }
        return tl::unexpected(
            err("the camera has no exposure feature (looked for ExposureTime, ExposureTimeAbs, "
                "ExposureTimeRaw)"));
    }

    Expected<double> read_exposure_us(const ExposureFeature& f) {
        if (f.name == "ExposureTimeRaw") {
            auto raw = get_int("ExposureTimeRaw");
            if (!raw) {
                return tl::unexpected(raw.error());
            }
            return static_cast<double>(*raw) * f.us_per_unit;
        }
        auto v = get_float(f.name.c_str());
        if (!v) {
            return v;
        }
        return *v * f.us_per_unit;
    }

    Expected<void> set_exposure_us(double us) {
        if (!(us > 0) || !std::isfinite(us)) {
            return tl::unexpected(err("exposure " + fmt_number(us) + " us is not positive"));
        }
        auto_off();
        auto f = exposure_feature();
        if (!f) {
            return tl::unexpected(f.error());
        }
        // A relative tolerance for the rounding of a value read back from the camera.
        const double tol = 1e-9 * std::max(1.0, std::abs(f->max_us));
        if (us < f->min_us - tol || us > f->max_us + tol) {
            return tl::unexpected(err("exposure " + fmt_number(us) + " us outside the range [" +
                                      fmt_number(f->min_us) + ", " + fmt_number(f->max_us) +
                                      "] us of " + f->name));
        }
        Expected<void> r;
        if (f->name == "ExposureTimeRaw") {
            r = set_int("ExposureTimeRaw", std::llround(us / f->us_per_unit));
        } else {
            r = set_float(f->name.c_str(), std::clamp(us, f->min_us, f->max_us) / f->us_per_unit);
        }
        if (!r) {
            return r;
        }
        // The camera rounds to its own step: stamp frames with what it actually uses.
        auto actual = read_exposure_us(*f);
        if (!actual) {
            return tl::unexpected(actual.error());
        }
        exposure_us = *actual;
        exposure_known = true;
        return {};
    }

    Expected<GainFeature> gain_feature() {
        GainFeature g;
        if (has_entry("GainSelector", "All")) {
            (void)set_enum("GainSelector", "All");
        }
        ArvGcNode* n = node("Gain");
        if (n != nullptr && ARV_IS_GC_FLOAT(n) && has("Gain")) {
            g.name = "Gain";
            const char* unit = arv_gc_float_get_unit(ARV_GC_FLOAT(n));
            g.unit = unit != nullptr && *unit != '\0' ? unit : "dB";
            GError* e = nullptr;
            g.min = arv_gc_float_get_min(ARV_GC_FLOAT(n), &e);
            if (e == nullptr) {
                g.max = arv_gc_float_get_max(ARV_GC_FLOAT(n), &e);
            }
            if (e != nullptr) {
                return tl::unexpected(err("range of Gain: " + take_message(e)));
            }
            if (auto r = check_range("Gain", g.min, g.max); !r) {
                return tl::unexpected(r.error());
            }
            return g;
        }
        if (has("GainRaw")) {
            g.name = "GainRaw";
            g.unit = "raw";
            auto range = int_range("GainRaw");
            if (!range) {
                return tl::unexpected(range.error());
            }
            g.min = static_cast<double>(range->first);
            g.max = static_cast<double>(range->second);
        }
        return g;
    }

    Expected<void> set_gain_native(double value) {
        auto_off();
        auto g = gain_feature();
        if (!g) {
            return tl::unexpected(g.error());
        }
        if (g->name.empty()) {
            return tl::unexpected(err("the camera has no gain feature (looked for Gain, GainRaw)"));
        }
        if (!std::isfinite(value) || value < g->min || value > g->max) {
            return tl::unexpected(err("gain " + fmt_number(value) + " " + g->unit +
                                      " outside the range [" + fmt_number(g->min) + ", " +
                                      fmt_number(g->max) + "] " + g->unit + " of " + g->name));
        }
        if (g->name == "GainRaw") {
            return set_int("GainRaw", std::llround(value));
        }
        return set_float("Gain", value);
    }

    Expected<void> set_gain_linear(double factor) {
        if (!(factor > 0) || !std::isfinite(factor)) {
            return tl::unexpected(err("gain factor " + fmt_number(factor) + " is not positive"));
        }
        auto g = gain_feature();
        if (!g) {
            return tl::unexpected(g.error());
        }
        if (g->name.empty()) {
            if (factor == 1) {
                gain = 1;
                return {};  // no gain stage: unity is what the camera does
            }
            return tl::unexpected(err("gain " + fmt_number(factor) +
                                      ": the camera has no gain feature (looked for Gain, "
                                      "GainRaw)"));
        }
        if (g->name == "GainRaw") {
            if (factor != 1) {
                return tl::unexpected(
                    err("gain " + fmt_number(factor) +
                        " (linear): the camera has only GainRaw, in raw units with no known "
                        "linear scale; only gain 1 (GainRaw at its minimum " +
                        fmt_number(g->min) + ") can be asked for"));
            }
            if (auto r = set_gain_native(g->min); !r) {
                return r;
            }
            gain = 1;
            return {};
        }
        if (g->unit != "dB") {
            return tl::unexpected(err("gain " + fmt_number(factor) + " (linear): Gain is in '" +
                                      g->unit + "', not dB, so a linear factor cannot be set"));
        }
        const double db = 20 * std::log10(factor);
        if (db < g->min - 1e-9 || db > g->max + 1e-9) {
            return tl::unexpected(err("gain " + fmt_number(factor) +
                                      " (linear) = " + fmt_number(db) + " dB outside the range [" +
                                      fmt_number(g->min) + ", " + fmt_number(g->max) +
                                      "] dB of Gain"));
        }
        if (auto r = set_gain_native(std::clamp(db, g->min, g->max)); !r) {
            return r;
        }
        auto actual = get_float("Gain");
        if (!actual) {
            return tl::unexpected(actual.error());
        }
        gain = std::pow(10.0, *actual / 20);
        return {};
    }

    // ---- stream -----------------------------------------------------------------------------

    Expected<void> ensure_stream() {
        if (stream != nullptr) {
            return {};
        }
        GError* e = nullptr;
        const guint size = arv_camera_get_payload(camera, &e);
        if (e != nullptr) {
            return tl::unexpected(err("reading PayloadSize: " + take_message(e)));
        }
        if (size == 0) {
            return tl::unexpected(err("PayloadSize is 0"));
        }
        stream = arv_camera_create_stream(camera, nullptr, nullptr, &e);
        if (e != nullptr || stream == nullptr) {
            stream = nullptr;
            return tl::unexpected(err("creating the stream: " + take_message(e)));
        }
        if (ARV_IS_GV_STREAM(stream)) {
            g_object_set(stream,
                         "packet-resend",
                         options.packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS
                                               : ARV_GV_STREAM_PACKET_RESEND_NEVER,
                         nullptr);
        }
        payload = size;
        buffers = std::max(1, options.n_buffers);
        for (int i = 0; i < buffers; ++i) {
            arv_stream_push_buffer(stream, arv_buffer_new_allocate(payload));
        }
        ++stats.streams_opened;
        return {};
    }

    /// Gives the stream at least `n` buffers (a line-triggered stream holds the frames of a
    /// whole sweep while its host is busy).
    void reserve_buffers(int n) {
        for (; stream != nullptr && buffers < n; ++buffers) {
            arv_stream_push_buffer(stream, arv_buffer_new_allocate(payload));
        }
    }

    /// After a capture that got no good frame: stops the acquisition and closes the stream, so
    /// that the next capture starts on a new one. A stream whose receiver took packets that were
    /// not its camera's (Aravis's packet socket sees every datagram of the interface until its
    /// filter is attached) can go on discarding that camera's frames as late; a new stream does
    /// not inherit that state.
    void reset_stream_after_failure() {
        (void)stop_acquisition();
        drop_stream();
    }

    AravisStreamStats stream_counters() const {
        AravisStreamStats s;
        if (stream == nullptr) {
            return s;
        }
        guint64 completed = 0, failures = 0, underruns = 0;
        arv_stream_get_statistics(stream, &completed, &failures, &underruns);
        s.underruns = underruns;
        if (ARV_IS_GV_STREAM(stream)) {
            guint64 resent = 0, missing = 0;
            arv_gv_stream_get_statistics(ARV_GV_STREAM(stream), &resent, &missing);
            s.resent_packets = resent;
            s.missing_packets = missing;
        }
        return s;
    }

    void drop_stream() {
        if (stream == nullptr) {
            return;
        }
        const AravisStreamStats s = stream_counters();
        stream_base.underruns += s.underruns;
        stream_base.resent_packets += s.resent_packets;
        stream_base.missing_packets += s.missing_packets;
        g_object_unref(stream);
        stream = nullptr;
    }

    AravisStreamStats all_stats() const {
        AravisStreamStats s = stats;
        const AravisStreamStats live = stream_counters();
        s.underruns = stream_base.underruns + live.underruns;
        s.resent_packets = stream_base.resent_packets + live.resent_packets;
        s.missing_packets = stream_base.missing_packets + live.missing_packets;
        return s;
    }

    /// BlackLevel when it is a Float in DN (digital numbers: counts of the current pixel format),
    /// else 0: other units (percent, raw register steps) say nothing about counts, and dark frames
    /// remove the offset anyway.
    void refresh_black_level() {
        black_level = 0;
        ArvGcNode* n = node("BlackLevel");
        if (n == nullptr || !ARV_IS_GC_FLOAT(n) || !has("BlackLevel")) {
            return;
        }
        const char* unit = arv_gc_float_get_unit(ARV_GC_FLOAT(n));
        if (unit == nullptr || (std::strcmp(unit, "DN") != 0 && std::strcmp(unit, "counts") != 0)) {
            return;
        }
        if (auto v = get_float("BlackLevel"); v && std::isfinite(*v) && *v >= 0) {
            black_level = *v;
        }
    }

    Expected<void> start_acquisition() {
        if (auto r = ensure_stream(); !r) {
            return r;
        }
        refresh_black_level();
        // The transport-layer parameters (payload size, packet size...) must not change while a
        // stream runs (SFNC, TLParamsLocked): lock them before AcquisitionStart.
        if (has("TLParamsLocked")) {
            if (auto r = set_int("TLParamsLocked", 1); !r) {
                return r;
            }
        }
        GError* e = nullptr;
        arv_camera_start_acquisition(camera, &e);
        if (e != nullptr) {
            const std::string m = take_message(e);
            if (has("TLParamsLocked")) {
                (void)set_int("TLParamsLocked", 0);
            }
            return tl::unexpected(err("AcquisitionStart: " + m));
        }
        acquiring = true;
        return {};
    }

    Expected<void> stop_acquisition() {
        if (!acquiring) {
            return {};
        }
        acquiring = false;
        GError* e = nullptr;
        arv_camera_stop_acquisition(camera, &e);
        std::string m = e != nullptr ? take_message(e) : "";
        if (has("TLParamsLocked")) {
            if (auto r = set_int("TLParamsLocked", 0); !r && m.empty()) {
                m = r.error().message;
            }
        }
        if (!m.empty()) {
            return tl::unexpected(err("AcquisitionStop: " + m));
        }
        return {};
    }

    /// Stops everything so that stream-shaping features (PixelFormat, Width...) may change.
    Expected<void> idle(bool payload_changes) {
        streaming = false;
        auto r = stop_acquisition();
        if (payload_changes) {
            drop_stream();
        }
        return r;
    }

    Expected<void> choose_trigger() {
        if (trigger != TriggerMethod::kUnknown) {
            return {};
        }
        if (has("TriggerSoftware") && has_entry("TriggerMode", "On") &&
            has_entry("TriggerSource", "Software")) {
            trigger = TriggerMethod::kSoftware;
        } else {
            trigger = TriggerMethod::kSingleFrame;
        }
        return {};
    }

    Expected<void> arm_software_trigger() {
        if (acquiring) {
            return {};
        }
        if (has_entry("TriggerSelector", "FrameStart")) {
            if (auto r = set_enum("TriggerSelector", "FrameStart"); !r) {
                return r;
            }
        }
        if (auto r = set_enum("TriggerMode", "On"); !r) {
            return r;
        }
        if (auto r = set_enum("TriggerSource", "Software"); !r) {
            return r;
        }
        if (has_entry("AcquisitionMode", "Continuous")) {
            if (auto r = set_enum("AcquisitionMode", "Continuous"); !r) {
                return r;
            }
        }
        return start_acquisition();
    }

    /// Gives back every frame already waiting (a triggered capture wants only its own frame).
    void drain() {
        while (ArvBuffer* b = arv_stream_try_pop_buffer(stream)) {
            arv_stream_push_buffer(stream, b);
        }
    }

    /// Why no frame came: the camera gone, control lost, or only the frame.
    std::string silence_reason() {
        if (control_lost) {
            return "control of the camera was lost (heartbeat not acknowledged: camera "
                   "disconnected, powered off or taken by another host)";
        }
        guint32 v = 0;
        GError* e = nullptr;
        // Address 0 is the first bootstrap register of both GigE Vision and USB3 Vision.
        if (ARV_IS_GV_DEVICE(device)) {
            arv_device_read_register(device, 0, &v, &e);
        } else {
            arv_device_read_memory(device, 0, 4, &v, &e);
        }
        if (e != nullptr) {
            return "the camera no longer answers (" + take_message(e) +
                   "): disconnected or powered off";
        }
        return "the camera still answers: the frame was lost or the trigger ignored";
    }

    /// Whether frames are matched to their trigger by time: unknown until the first frame after a
    /// latch (kOn when its timestamp is on the latch's clock, kOff otherwise, e.g. a camera that
    /// stamps frames with the host's time or latches nothing useful).
    enum class StaleCheck { kUnknown, kOn, kOff };
    StaleCheck stale_check = StaleCheck::kUnknown;
    double timestamp_ns_per_tick = 0;  ///< 0: not read yet
    std::uint64_t first_latch_ns = 0;  ///< The latch before this camera's first trigger.
    bool first_latch_ns_set = false;

    /// The camera's clock now, in ns (GigE Vision's GevTimestampControlLatch / GevTimestampValue,
    /// or SFNC's TimestampLatch / TimestampLatchValue), when it has a latch.
    std::optional<std::uint64_t> latch_timestamp_ns() {
        if (stale_check == StaleCheck::kOff) {
            return std::nullopt;
        }
        const bool gev = has("GevTimestampControlLatch") && has("GevTimestampValue");
        const bool sfnc = !gev && has("TimestampLatch") && has("TimestampLatchValue");
        if (!gev && !sfnc) {
            stale_check = StaleCheck::kOff;
            return std::nullopt;
        }
        if (timestamp_ns_per_tick == 0) {
            // GigE Vision counts ticks of GevTimestampTickFrequency; SFNC's latch value is in ns.
            timestamp_ns_per_tick = 1;
            if (gev && has("GevTimestampTickFrequency")) {
                auto f = get_int("GevTimestampTickFrequency");
                if (f && *f > 0) {
                    timestamp_ns_per_tick = 1e9 / static_cast<double>(*f);
                }
            }
        }
        if (!execute(gev ? "GevTimestampControlLatch" : "TimestampLatch")) {
            stale_check = StaleCheck::kOff;
            return std::nullopt;
        }
        auto v = get_int(gev ? "GevTimestampValue" : "TimestampLatchValue");
        if (!v || *v < 0) {
            stale_check = StaleCheck::kOff;
            return std::nullopt;
        }
        const auto ns = static_cast<std::uint64_t>(static_cast<double>(*v) * timestamp_ns_per_tick);
        if (!first_latch_ns_set) {
            first_latch_ns = ns;
            first_latch_ns_set = true;
        }
        return ns;
    }

    /// The frame of the trigger sent after the camera's clock read `not_before_ns` (nullopt: the
    /// first frame). A frame stamped earlier is the late frame of an earlier trigger whose capture
    /// timed out: counted and set aside. The first frame decides whether the camera's frame stamps
    /// run on the latch's clock at all: no frame can be stamped before the latch that preceded the
    /// camera's first trigger.
    Expected<Frame> pop_triggered_frame(std::chrono::milliseconds timeout,
                                        std::optional<std::uint64_t> not_before_ns) {
        using Clock = std::chrono::steady_clock;
        const auto deadline = Clock::now() + std::max(timeout, std::chrono::milliseconds(1));
        for (;;) {
            const auto left =
                std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
            Expected<Frame> f = pop_frame(std::max(left, std::chrono::milliseconds(1)), timeout);
            if (!f || !not_before_ns) {
                return f;
            }
            const auto stamp =
                static_cast<std::uint64_t>(std::max<std::int64_t>(f->timestamp_ns, 0));
            if (stale_check == StaleCheck::kUnknown) {
                // Every frame of this camera, late or not, follows the latch before its first
                // trigger when the frame stamps run on the latch's clock.
                stale_check = stamp >= first_latch_ns ? StaleCheck::kOn : StaleCheck::kOff;
            }
            if (stale_check == StaleCheck::kOff || stamp >= *not_before_ns) {
                return f;
            }
            ++stats.frames_stale;
            --stats.frames_completed;  // counted when decoded; not handed out
            if (Clock::now() >= deadline) {
                ++stats.frames_missing;
                return tl::unexpected(err("no frame within " + std::to_string(timeout.count()) +
                                          " ms: only the late frame " +
                                          std::to_string(f->frame_id) +
                                          " of an earlier trigger came"));
            }
        }
    }

    /// The next complete frame within `timeout`; a timeout's message names `said` (the caller's
    /// whole timeout) when given.
    Expected<Frame> pop_frame(std::chrono::milliseconds timeout,
                              std::chrono::milliseconds said = std::chrono::milliseconds(0)) {
        if (said.count() <= 0) {
            said = timeout;
        }
        if (stream == nullptr) {
            return tl::unexpected(err("no stream"));
        }
        using Clock = std::chrono::steady_clock;
        const auto deadline = Clock::now() + std::max(timeout, std::chrono::milliseconds(1));
        for (;;) {
            const auto left =
                std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now());
            ArvBuffer* buffer = left.count() > 0 ? arv_stream_timeout_pop_buffer(
                                                       stream, static_cast<guint64>(left.count()))
                                                 : nullptr;
            if (buffer == nullptr) {
                ++stats.frames_missing;
                return tl::unexpected(err("no frame within " + std::to_string(said.count()) +
                                          " ms: " + silence_reason()));
            }
            if (arv_buffer_get_status(buffer) == ARV_BUFFER_STATUS_CLEARED) {
                // Handed back without any frame data in it (no image of the camera's was lost):
                // recycle it and keep waiting for the frame.
                ++stats.buffers_recycled;
                arv_stream_push_buffer(stream, buffer);
                continue;
            }
            Expected<Frame> frame = decode(buffer);
            arv_stream_push_buffer(stream, buffer);
            return frame;
        }
    }

    Expected<Frame> decode(ArvBuffer* buffer) {
        const ArvBufferStatus status = arv_buffer_get_status(buffer);
        const guint64 id = arv_buffer_get_frame_id(buffer);
        if (status != ARV_BUFFER_STATUS_SUCCESS) {
            ++stats.frames_incomplete;
            const AravisStreamStats s = all_stats();
            return tl::unexpected(err("frame " + std::to_string(id) +
                                      " incomplete: " + buffer_status_name(status) + " (" +
                                      std::to_string(s.missing_packets) + " packets missing and " +
                                      std::to_string(s.resent_packets) + " resent so far)"));
        }
        const ArvBufferPayloadType type = arv_buffer_get_payload_type(buffer);
        if (type != ARV_BUFFER_PAYLOAD_TYPE_IMAGE &&
            type != ARV_BUFFER_PAYLOAD_TYPE_EXTENDED_CHUNK_DATA) {
            ++stats.frames_incomplete;
            return tl::unexpected(err("frame " + std::to_string(id) + ": payload type " +
                                      std::to_string(static_cast<int>(type)) + " is not an image"));
        }
        const auto pfnc = static_cast<std::uint32_t>(arv_buffer_get_image_pixel_format(buffer));
        auto format = find_pixel_format(pfnc);
        if (!format) {
            ++stats.frames_incomplete;
            char code[16];
            std::snprintf(code, sizeof code, "0x%08X", pfnc);
            return tl::unexpected(err("frame " + std::to_string(id) + ": pixel format " + code +
                                      " is not a mono or Bayer format gonio decodes"));
        }
        const int w = arv_buffer_get_image_width(buffer);
        const int h = arv_buffer_get_image_height(buffer);
        gint pad_x = 0, pad_y = 0;
        arv_buffer_get_image_padding(buffer, &pad_x, &pad_y);
        size_t size = 0;
        const void* data = arv_buffer_get_image_data(buffer, &size);
        auto image = unpack_pixels(
            static_cast<const std::uint8_t*>(data), size, *format, w, h, std::max(0, pad_x));
        if (!image) {
            ++stats.frames_incomplete;
            return tl::unexpected(
                err("frame " + std::to_string(id) + ": " + image.error().message));
        }
        Frame f;
        f.image = std::move(*image);
        f.exposure_us = exposure_us;
        f.gain = gain;
        const guint64 ts = arv_buffer_get_timestamp(buffer);
        f.timestamp_ns =
            static_cast<std::int64_t>(ts != 0 ? ts : arv_buffer_get_system_timestamp(buffer));
        f.black_level = black_level;
        f.bit_depth = format->bits;
        f.saturation_level = std::ldexp(1.0, format->bits) - 1;
        f.frame_id = id;
        f.linear = true;
        f.pixel_format = format->name;
        f.cfa = format->cfa;
        ++stats.frames_completed;
        return f;
    }
};

namespace {

Expected<std::unique_ptr<AravisCamera::Impl>> wrap(ArvCamera* camera,
                                                   const std::string& address,
                                                   AravisOptions options) {
    auto impl = std::make_unique<AravisCamera::Impl>();
    impl->camera = camera;
    impl->device = arv_camera_get_device(camera);
    impl->options = options;
    impl->address = address;
    const std::string vendor = impl->string_or_empty("DeviceVendorName");
    const std::string model = impl->string_or_empty("DeviceModelName");
    GError* e = nullptr;
    const char* id = arv_camera_get_device_id(camera, &e);
    std::string ident = e == nullptr && id != nullptr ? id : "";
    if (e != nullptr) {
        g_error_free(e);
    }
    impl->name = "camera " + vendor + (vendor.empty() ? "" : " ") + model +
                 (ident.empty() ? "" : " (" + ident + ")") + " at " + address;
    impl->control_lost_handler = g_signal_connect(
        impl->device, "control-lost", G_CALLBACK(&AravisCamera::Impl::on_control_lost), impl.get());
    if (options.heartbeat_timeout_ms > 0 && impl->has("GevHeartbeatTimeout")) {
        if (auto r = impl->set_int("GevHeartbeatTimeout", options.heartbeat_timeout_ms); !r) {
            return tl::unexpected(r.error());
        }
    }
    return impl;
}

}  // namespace

AravisCamera::AravisCamera(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AravisCamera::~AravisCamera() = default;

Expected<std::unique_ptr<AravisCamera>> AravisCamera::open_id(const std::string& device_id,
                                                              AravisOptions options) {
    const std::string address = "aravis:" + device_id;
    if (device_id.empty()) {
        return make_error("camera address 'aravis:': empty device id (see `gonio devices`)");
    }
    GError* e = nullptr;
    ArvCamera* cam = arv_camera_new(device_id.c_str(), &e);
    if (cam == nullptr || e != nullptr) {
        if (cam != nullptr) {
            g_object_unref(cam);
        }
        return make_error(address + ": " + take_message(e) +
                          " (`gonio devices` or `arv-tool-0.8` list the device ids)");
    }
    auto impl = wrap(cam, address, options);
    if (!impl) {
        return tl::unexpected(impl.error());
    }
    return std::unique_ptr<AravisCamera>(new AravisCamera(std::move(*impl)));
}

Expected<std::unique_ptr<AravisCamera>> AravisCamera::open_gige(const std::string& host,
                                                                AravisOptions options) {
    const std::string address = "gige://" + host;
    if (host.empty()) {
        return make_error("camera address 'gige://': empty host");
    }
    auto ip = resolve_ipv4(host);
    if (!ip) {
        return tl::unexpected(with_context(address, ip.error()));
    }
    auto local = local_address_towards(*ip);
    if (!local) {
        return tl::unexpected(with_context(address, local.error()));
    }
    GInetAddress* dev_addr = g_inet_address_new_from_string(ip->c_str());
    GInetAddress* if_addr = g_inet_address_new_from_string(local->c_str());
    GError* e = nullptr;
    ArvDevice* device = arv_gv_device_new(if_addr, dev_addr, &e);
    g_object_unref(dev_addr);
    g_object_unref(if_addr);
    if (device == nullptr || e != nullptr) {
        if (device != nullptr) {
            g_object_unref(device);
        }
        return make_error(address + ": no GigE Vision camera answers at " + *ip + " (from " +
                          *local + "): " + take_message(e));
    }
    ArvCamera* cam = arv_camera_new_with_device(device, &e);
    g_object_unref(device);  // the camera holds its own reference
    if (cam == nullptr || e != nullptr) {
        if (cam != nullptr) {
            g_object_unref(cam);
        }
        return make_error(address + ": " + take_message(e));
    }
    auto impl = wrap(cam, address, options);
    if (!impl) {
        return tl::unexpected(impl.error());
    }
    return std::unique_ptr<AravisCamera>(new AravisCamera(std::move(*impl)));
}

Expected<std::unique_ptr<AravisCamera>> AravisCamera::open_u3v(const std::string& serial,
                                                               AravisOptions options) {
    const std::string address = "u3v://" + serial;
    if (serial.empty()) {
        return make_error("camera address 'u3v://': empty serial number");
    }
    ArvInterface* iface = arv_uv_interface_get_instance();
    arv_interface_update_device_list(iface);
    const unsigned n = arv_interface_get_n_devices(iface);
    std::string id;
    std::string seen;
    for (unsigned i = 0; i < n; ++i) {
        const char* s = arv_interface_get_device_serial_nbr(iface, i);
        const char* d = arv_interface_get_device_id(iface, i);
        seen += std::string(seen.empty() ? "" : ", ") + (s != nullptr ? s : "?");
        if (s != nullptr && serial == s && d != nullptr) {
            id = d;
        }
    }
    if (id.empty()) {
        return make_error(address + ": no USB3 Vision camera with serial " + serial +
                          " among the " + std::to_string(n) + " Aravis can open" +
                          (seen.empty() ? "" : " (" + seen + ")") +
                          "; a camera without permission is shown by `gonio devices` with the "
                          "udev rule that fixes it");
    }
    GError* e = nullptr;
    ArvDevice* device = arv_interface_open_device(iface, id.c_str(), &e);
    if (device == nullptr || e != nullptr) {
        if (device != nullptr) {
            g_object_unref(device);
        }
        return make_error(address + " (" + id + "): " + take_message(e));
    }
    ArvCamera* cam = arv_camera_new_with_device(device, &e);
    g_object_unref(device);
    if (cam == nullptr || e != nullptr) {
        if (cam != nullptr) {
            g_object_unref(cam);
        }
        return make_error(address + " (" + id + "): " + take_message(e));
    }
    auto impl = wrap(cam, address, options);
    if (!impl) {
        return tl::unexpected(impl.error());
    }
    return std::unique_ptr<AravisCamera>(new AravisCamera(std::move(*impl)));
}

Expected<CameraInfo> AravisCamera::info() {
    auto& d = *impl_;
    CameraInfo i;
    i.vendor = d.string_or_empty("DeviceVendorName");
    i.model = d.string_or_empty("DeviceModelName");
    i.serial = d.string_or_empty("DeviceSerialNumber");
    if (i.serial.empty()) {
        i.serial = d.string_or_empty("DeviceID");
    }
    i.version = d.string_or_empty("DeviceVersion");
    // The sensor's size: SensorWidth/SensorHeight (SFNC) where the camera has them; else
    // WidthMax/HeightMax (the largest image it sends); else the top of Width's/Height's range.
    // Several real cameras describe only the latter two. Some describe Width and Height as plain
    // registers or as Integers without a maximum (the top of the range is then the register's,
    // 2^32 - 1): their size is the current Width and Height, and the info says so.
    struct Extent {
        int pixels = 0;
        std::string from;
    };
    const auto pixel_count = [](std::int64_t v) {
        return v >= 1 && v <= std::numeric_limits<int>::max();
    };
    const auto extent = [&d, &pixel_count](const char* sensor,
                                           const char* max_feature,
                                           const char* size) -> Expected<Extent> {
        for (const char* f : {sensor, max_feature}) {
            if (d.has(f)) {
                auto v = d.get_int(f);
                if (!v) {
                    return tl::unexpected(v.error());
                }
                if (!pixel_count(*v)) {
                    return tl::unexpected(d.err(std::string(f) + " = " + std::to_string(*v) +
                                                " is not a size in pixels"));
                }
                return Extent{static_cast<int>(*v), f};
            }
        }
        if (auto r = d.require(size,
                               std::string("for the sensor size (the camera has neither ") +
                                   sensor + " nor " + max_feature + ")");
            !r) {
            return tl::unexpected(r.error());
        }
        auto range = d.int_range(size);
        if (!range) {
            return tl::unexpected(range.error());
        }
        if (pixel_count(range->second)) {
            return Extent{static_cast<int>(range->second),
                          "the top of " + std::string(size) + "'s range"};
        }
        auto now = d.get_int(size);
        if (!now) {
            return tl::unexpected(now.error());
        }
        if (!pixel_count(*now)) {
            return tl::unexpected(d.err(
                "the top of " + std::string(size) + "'s range, " + std::to_string(range->second) +
                ", is not a size in pixels, nor is its current value, " + std::to_string(*now)));
        }
        return Extent{static_cast<int>(*now), "current"};
    };
    auto w = extent("SensorWidth", "WidthMax", "Width");
    if (!w) {
        return tl::unexpected(w.error());
    }
    auto h = extent("SensorHeight", "HeightMax", "Height");
    if (!h) {
        return tl::unexpected(h.error());
    }
    i.sensor_width = w->pixels;
    i.sensor_height = h->pixels;
    if (w->from == "current" || h->from == "current") {
        i.sensor_size_from =
            "the current Width and Height; the camera's description gives them no maximum";
    } else if (w->from == "SensorWidth" && h->from == "SensorHeight") {
        i.sensor_size_from = "SensorWidth and SensorHeight";
    } else {
        i.sensor_size_from = w->from + " and " + h->from;
    }
    GError* e = nullptr;
    const char* pf = arv_camera_get_pixel_format_as_string(d.camera, &e);
    if (e != nullptr) {
        return tl::unexpected(d.err("reading PixelFormat: " + take_message(e)));
    }
    auto format = find_pixel_format(pf != nullptr ? pf : "");
    i.bit_depth = format ? format->bits : 0;
    return i;
}

Expected<void> AravisCamera::set_exposure_us(double exposure_us) {
    return impl_->set_exposure_us(exposure_us);
}

Expected<double> AravisCamera::exposure_us() {
    auto f = impl_->exposure_feature();
    if (!f) {
        return tl::unexpected(f.error());
    }
    return impl_->read_exposure_us(*f);
}

Expected<void> AravisCamera::set_gain(double gain) {
    return impl_->set_gain_linear(gain);
}

Expected<void> AravisCamera::set_gain_native(double value) {
    if (auto r = impl_->set_gain_native(value); !r) {
        return r;
    }
    auto g = impl_->gain_feature();
    if (g && g->unit == "dB") {
        auto actual = impl_->get_float("Gain");
        if (actual) {
            impl_->gain = std::pow(10.0, *actual / 20);
        }
    } else {
        // Raw gain has no linear scale: frames carry 1 and the caller knows the raw setting.
        impl_->gain = 1;
    }
    return {};
}

Expected<void> AravisCamera::set_pixel_format(PixelFormat f) {
    return set_pixel_format_name(to_string(f));
}

Expected<std::vector<std::string>> AravisCamera::pixel_formats() {
    auto& d = *impl_;
    if (auto r = d.require("PixelFormat", "to list pixel formats"); !r) {
        return tl::unexpected(r.error());
    }
    GError* e = nullptr;
    guint n = 0;
    const char** names = arv_camera_dup_available_pixel_formats_as_strings(d.camera, &n, &e);
    if (e != nullptr) {
        return tl::unexpected(d.err("listing PixelFormat entries: " + take_message(e)));
    }
    std::vector<std::string> out;
    for (guint i = 0; i < n; ++i) {
        out.emplace_back(names[i] != nullptr ? names[i] : "");
    }
    g_free(static_cast<gpointer>(names));
    return out;
}

Expected<void> AravisCamera::set_pixel_format_name(const std::string& name) {
    auto& d = *impl_;
    if (auto r = d.require("PixelFormat", "to choose the pixel format"); !r) {
        return r;
    }
    if (!find_pixel_format(name)) {
        return tl::unexpected(d.err("pixel format '" + name +
                                    "' is not a mono or Bayer format gonio decodes (Mono8/10/12/"
                                    "14/16, Mono10/12Packed, Mono10/12p, Bayer..8/10/12/16 and "
                                    "their packed forms)"));
    }
    GError* e = nullptr;
    const char* current = arv_camera_get_pixel_format_as_string(d.camera, &e);
    if (e != nullptr) {
        return tl::unexpected(d.err("reading PixelFormat: " + take_message(e)));
    }
    if (current != nullptr && name == current) {
        return {};
    }
    if (!d.has_entry("PixelFormat", name.c_str())) {
        std::string list;
        if (auto all = pixel_formats()) {
            for (const auto& s : *all) {
                list += (list.empty() ? "" : ", ") + s;
            }
        }
        return tl::unexpected(
            d.err("PixelFormat has no entry '" + name + "' (available: " + list + ")"));
    }
    if (auto r = d.idle(true); !r) {
        return r;
    }
    return d.set_enum("PixelFormat", name.c_str());
}

Expected<void> AravisCamera::set_roi(const Roi& roi) {
    auto& d = *impl_;
    if (roi.x < 0 || roi.y < 0 || roi.width < 0 || roi.height < 0) {
        return tl::unexpected(d.err("region of interest x " + std::to_string(roi.x) + " y " +
                                    std::to_string(roi.y) + " " + std::to_string(roi.width) +
                                    " x " + std::to_string(roi.height) + " has a negative value"));
    }
    for (const char* f : {"Width", "Height"}) {
        if (auto r = d.require(f, "for a region of interest"); !r) {
            return r;
        }
    }
    if ((roi.x != 0 && !d.has("OffsetX")) || (roi.y != 0 && !d.has("OffsetY"))) {
        return tl::unexpected(d.err(std::string("the camera has no feature ") +
                                    (roi.x != 0 && !d.has("OffsetX") ? "OffsetX" : "OffsetY") +
                                    " (needed for a region of interest not at the origin)"));
    }
    if (auto r = d.idle(true); !r) {
        return r;
    }
    // Offsets to 0 first so that any width up to the sensor's is allowed, then the size, then
    // the offsets the size now allows.
    for (const char* f : {"OffsetX", "OffsetY"}) {
        if (d.has(f)) {
            if (auto r = d.set_int(f, 0); !r) {
                return r;
            }
        }
    }
    struct Axis {
        const char* size;
        const char* offset;
        int want_size;
        int want_offset;
    };
    for (const Axis& a : {Axis{"Width", "OffsetX", roi.width, roi.x},
                          Axis{"Height", "OffsetY", roi.height, roi.y}}) {
        auto range = d.int_range(a.size);
        if (!range) {
            return tl::unexpected(range.error());
        }
        const std::int64_t lo = range->first;
        const std::int64_t hi = range->second;
        if (a.want_size == 0 && a.want_offset == 0 && hi > std::numeric_limits<int>::max()) {
            // The full frame of a camera whose description gives this size no maximum (a plain
            // register): the current size, as info() reports it.
            continue;
        }
        GError* e = nullptr;
        const std::int64_t size = a.want_size == 0 ? hi - a.want_offset : a.want_size;
        if (size < lo || size > hi || size + a.want_offset > hi) {
            return tl::unexpected(d.err(std::string(a.size) + " " + std::to_string(size) +
                                        " at offset " + std::to_string(a.want_offset) +
                                        " outside the sensor: " + a.size + " range [" +
                                        std::to_string(lo) + ", " + std::to_string(hi) + "]"));
        }
        const gint64 inc = arv_device_get_integer_feature_increment(d.device, a.size, &e);
        if (e != nullptr) {
            g_error_free(e);
        } else if (inc > 1 && (size - lo) % inc != 0) {
            return tl::unexpected(d.err(std::string(a.size) + " " + std::to_string(size) +
                                        " is not on the camera's step of " + std::to_string(inc) +
                                        " from " + std::to_string(lo)));
        }
        if (auto r = d.set_int(a.size, size); !r) {
            return r;
        }
        if (a.want_offset != 0) {
            if (auto r = d.set_int(a.offset, a.want_offset); !r) {
                return r;
            }
        }
    }
    return {};
}

Expected<Frame> AravisCamera::capture(std::chrono::milliseconds timeout) {
    auto& d = *impl_;
    if (d.streaming) {
        return tl::unexpected(d.err("capture: a stream is running (stop_stream first)"));
    }
    if (!d.exposure_known) {
        if (auto e = exposure_us()) {
            d.exposure_us = *e;
            d.exposure_known = true;
        }
    }
    (void)d.choose_trigger();
    if (d.trigger == TriggerMethod::kSoftware) {
        if (auto r = d.arm_software_trigger(); !r) {
            return tl::unexpected(r.error());
        }
        d.drain();
        // The camera's clock before the trigger: a frame stamped earlier is not this trigger's.
        const std::optional<std::uint64_t> before = d.latch_timestamp_ns();
        if (auto r = d.execute("TriggerSoftware"); !r) {
            // Say whether the camera is still there (a write that failed is usually a camera gone).
            return tl::unexpected(Error{r.error().message + "; " + d.silence_reason()});
        }
        auto frame = d.pop_triggered_frame(timeout, before);
        if (!frame) {
            d.reset_stream_after_failure();
        }
        return frame;
    }
    // No software trigger: one acquisition of a single frame per capture.
    if (d.has("TriggerMode")) {
        if (auto r = d.set_enum("TriggerMode", "Off"); !r) {
            return tl::unexpected(r.error());
        }
    }
    if (d.has_entry("AcquisitionMode", "SingleFrame")) {
        if (auto r = d.set_enum("AcquisitionMode", "SingleFrame"); !r) {
            return tl::unexpected(r.error());
        }
    }
    if (auto r = d.start_acquisition(); !r) {
        return tl::unexpected(r.error());
    }
    d.drain();
    auto frame = d.pop_frame(timeout);
    auto stop = d.stop_acquisition();
    if (!frame) {
        d.reset_stream_after_failure();
    } else if (!stop) {
        return tl::unexpected(stop.error());
    }
    return frame;
}

Expected<void> AravisCamera::start_stream() {
    auto& d = *impl_;
    if (auto r = d.idle(false); !r) {
        return r;
    }
    if (d.has_entry("TriggerMode", "Off")) {
        if (auto r = d.set_enum("TriggerMode", "Off"); !r) {
            return r;
        }
    }
    if (d.has("AcquisitionMode")) {
        if (auto r = d.set_enum("AcquisitionMode", "Continuous"); !r) {
            return r;
        }
    }
    return begin_streaming(0);
}

Expected<void> AravisCamera::start_line_stream(const std::string& line) {
    auto& d = *impl_;
    if (!d.has_entry("TriggerMode", "On") || !d.has_entry("TriggerSource", line.c_str())) {
        return tl::unexpected(d.err("no trigger input: TriggerMode On with TriggerSource " + line +
                                    " is not among its features"));
    }
    if (auto r = d.idle(false); !r) {
        return r;
    }
    const std::pair<const char*, std::string> settings[] = {{"TriggerSelector", "FrameStart"},
                                                            {"TriggerMode", "On"},
                                                            {"TriggerSource", line},
                                                            {"TriggerActivation", "RisingEdge"},
                                                            {"AcquisitionMode", "Continuous"}};
    for (const auto& [feature, entry] : settings) {
        if (std::string(feature) == "TriggerMode" || std::string(feature) == "TriggerSource" ||
            d.has_entry(feature, entry.c_str())) {
            if (auto r = d.set_enum(feature, entry.c_str()); !r) {
                return r;
            }
        }
    }
    return begin_streaming(kLineStreamBuffers);
}

Expected<void> AravisCamera::begin_streaming(int min_buffers) {
    auto& d = *impl_;
    if (!d.exposure_known) {
        if (auto e = exposure_us()) {
            d.exposure_us = *e;
            d.exposure_known = true;
        }
    }
    if (d.stream != nullptr) {
        d.drain();
    }
    if (auto r = d.start_acquisition(); !r) {
        return r;
    }
    d.reserve_buffers(min_buffers);
    d.streaming = true;
    return {};
}

Expected<Frame> AravisCamera::next_frame(std::chrono::milliseconds timeout) {
    auto& d = *impl_;
    if (!d.streaming) {
        return tl::unexpected(d.err("next_frame: no stream running (start_stream first)"));
    }
    return d.pop_frame(timeout);
}

Expected<void> AravisCamera::stop_stream() {
    auto& d = *impl_;
    if (!d.streaming) {
        return {};
    }
    d.streaming = false;
    auto r = d.stop_acquisition();
    // The next capture re-arms the trigger from scratch.
    return r;
}

Expected<ExposureFeature> AravisCamera::exposure_feature() {
    return impl_->exposure_feature();
}

Expected<GainFeature> AravisCamera::gain_feature() {
    return impl_->gain_feature();
}

std::string AravisCamera::trigger_method() const {
    auto& d = *impl_;
    (void)d.choose_trigger();
    return d.trigger == TriggerMethod::kSoftware ? "software trigger (TriggerSoftware)"
                                                 : "single frame (AcquisitionMode SingleFrame)";
}

const std::string& AravisCamera::name() const {
    return impl_->name;
}

Expected<std::string> AravisCamera::feature_string(const std::string& feature) {
    auto& d = *impl_;
    ArvGcNode* n = d.node(feature.c_str());
    if (n == nullptr || !ARV_IS_GC_FEATURE_NODE(n)) {
        return tl::unexpected(d.err("the camera has no feature " + feature));
    }
    GError* e = nullptr;
    const char* v = arv_gc_feature_node_get_value_as_string(ARV_GC_FEATURE_NODE(n), &e);
    if (e != nullptr) {
        return tl::unexpected(d.err("reading " + feature + ": " + take_message(e)));
    }
    return std::string(v != nullptr ? v : "");
}

AravisStreamStats AravisCamera::stream_stats() const {
    return impl_->all_stats();
}

Expected<std::vector<AravisDeviceEntry>> list_aravis_devices() {
    arv_update_device_list();
    std::vector<AravisDeviceEntry> out;
    const unsigned n = arv_get_n_devices();
    auto str = [](const char* s) { return std::string(s != nullptr ? s : ""); };
    for (unsigned i = 0; i < n; ++i) {
        AravisDeviceEntry e;
        e.id = str(arv_get_device_id(i));
        e.protocol = str(arv_get_device_protocol(i));
        e.vendor = str(arv_get_device_vendor(i));
        e.model = str(arv_get_device_model(i));
        e.serial = str(arv_get_device_serial_nbr(i));
        e.address = str(arv_get_device_address(i));
        e.physical_id = str(arv_get_device_physical_id(i));
        out.push_back(std::move(e));
    }
    return out;
}

}  // namespace gonio::devices
