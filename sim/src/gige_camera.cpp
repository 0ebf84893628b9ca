// The simulated GigE Vision camera: registers, GVCP handling, control-channel privilege,
// heartbeat, frame rendering.

#include "gonio/sim/gige_camera.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "gonio/base/check.h"
#include "gonio/devices/pixel_format.h"
#include "gonio/sim/camera_render.h"

namespace gonio::sim {

namespace gvcp = devices::gvcp;
namespace gvbs = devices::gvbs;
namespace m = gige_map;
using gvcp::Status;

namespace {

constexpr std::uint32_t kBootstrapSize = 0x1000;
constexpr bool kLittleEndianHost = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;
constexpr std::uint32_t kExposureTickNs = 100;
constexpr std::uint32_t kMinPacketSize = 576;
constexpr std::uint32_t kMaxPacketSize = 65500;
constexpr std::uint32_t kMinHeartbeatMs = 500;
constexpr double kMinFrameRate = 0.1;
constexpr double kMaxFrameRate = 200;

void put_string(std::vector<std::uint8_t>& b,
                std::uint32_t at,
                const std::string& s,
                std::size_t n) {
    // NUL-terminated within the field.
    const std::size_t len = std::min(s.size(), n - 1);
    std::memcpy(b.data() + at, s.data(), len);
}

std::uint32_t float_bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}

float bits_float(std::uint32_t u) {
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

struct PendingFrame {
    SceneState scene;
    ExposureSettings settings;
    devices::Roi roi;
    std::uint64_t timestamp_ns = 0;
};

}  // namespace

struct GigeCamera::State {
    std::vector<std::uint8_t> bootstrap = std::vector<std::uint8_t>(kBootstrapSize, 0);
    std::vector<std::uint8_t> xml_memory;
    // Control channel.
    std::optional<HostId> controller;
    std::uint32_t ccp = 0;
    Clock::time_point last_heard;
    std::uint32_t heartbeat_timeout_ms = 3000;
    // Stream channel 0.
    std::uint32_t scp = 0;
    std::uint32_t scps = 0;
    std::uint32_t scpd = 0;
    std::uint32_t scda = 0;
    std::uint16_t source_port = 0;
    // Timestamp.
    Clock::time_point t0 = Clock::now();
    std::uint64_t latched_ticks = 0;
    // Features.
    std::uint32_t width = 0, height = 0, offset_x = 0, offset_y = 0;
    std::uint32_t pixel_format = devices::kPfncMono16;
    std::uint32_t exposure_ticks = 100000;  // 10 ms
    std::uint32_t gain_selector = 0;
    std::uint32_t gain_centi_db[2] = {0, 0};
    std::uint32_t trigger_control = 0;
    std::uint32_t acquisition_control = 0;
    float frame_rate_hz = 10;
    std::uint32_t temperature_selector = 0;
    std::int32_t temperature_sixteenths[2] = {0, 0};
    // Acquisition.
    bool acquiring = false;
    Clock::time_point next_due;
    std::deque<PendingFrame> triggers;
    std::uint16_t block_id = 0;
    std::uint64_t frames_rendered = 0;
    double exposure_s_rendered = 0;
    std::uint64_t line_frames = 0;

    bool trigger_on() const { return (trigger_control & 1u) != 0; }
    std::uint32_t trigger_source() const { return (trigger_control >> 8) & 0xFFu; }
    bool falling_edge() const { return ((trigger_control >> 16) & 0xFFu) == 1; }
    bool tl_locked() const { return (acquisition_control & 1u) != 0; }
    bool single_frame() const { return ((acquisition_control >> 8) & 0xFFu) == 1; }
    devices::PixelFormat format() const {
        return devices::pixel_format_from_pfnc(pixel_format)
            .value_or(devices::PixelFormat::kMono16);
    }
    ExposureSettings settings() const {
        const double db = (gain_centi_db[0] + gain_centi_db[1]) / 100.0;
        return ExposureSettings{
            exposure_ticks * (kExposureTickNs / 1000.0), std::pow(10.0, db / 20.0), format()};
    }
};

GigeCamera::GigeCamera(GigeCameraConfig config,
                       std::shared_ptr<const brdf::Brdf> brdf,
                       SceneFn scene)
    : config_(std::move(config)),
      brdf_(std::move(brdf)),
      scene_(std::move(scene)),
      state_(std::make_unique<State>()),
      sensor_(config_.sensor) {
    GONIO_CHECK(config_.sensor.width > 0 && config_.sensor.width <= 65535);
    GONIO_CHECK(config_.sensor.height > 0 && config_.sensor.height <= 65535);
    xml_ = gige_camera_xml(config_);
    State& s = *state_;
    s.xml_memory.assign(xml_.begin(), xml_.end());
    // Device memory is read in 4-byte units: pad the file.
    s.xml_memory.resize((s.xml_memory.size() + 3) / 4 * 4, 0);
    auto& b = s.bootstrap;
    gvcp::put_u32(&b[gvbs::kVersion], (2u << 16) | 0u);  // GigE Vision 2.0
    // Big-endian registers, transmitter class, UTF-8 strings.
    gvcp::put_u32(&b[gvbs::kDeviceMode], 0x80000001u);
    // A locally administered MAC (bit 1 of the first byte).
    gvcp::put_u32(&b[gvbs::kMacHigh], 0x0000025Au);
    gvcp::put_u32(&b[gvbs::kMacLow], 0x494F0001u);
    gvcp::put_u32(&b[gvbs::kSupportedIpConfig], 0x00000007u);  // LLA, DHCP, persistent
    gvcp::put_u32(&b[gvbs::kCurrentIpConfig], 0x00000004u);    // LLA
    gvcp::put_u32(&b[gvbs::kCurrentIp], 0x7F000001u);          // 127.0.0.1
    gvcp::put_u32(&b[gvbs::kCurrentSubnetMask], 0xFF000000u);
    put_string(b, gvbs::kManufacturerName, config_.vendor, 32);
    put_string(b, gvbs::kModelName, config_.model, 32);
    put_string(b, gvbs::kDeviceVersion, config_.device_version, 32);
    put_string(b, gvbs::kManufacturerInfo, "renders a ground-truth BRDF", 48);
    put_string(b, gvbs::kSerialNumber, config_.serial, 16);
    const std::string url = "Local:SimCamGigE.xml;" + [&] {
        char buf[64];
        std::snprintf(buf,
                      sizeof buf,
                      "%X;%X",
                      static_cast<unsigned>(m::kXmlAddress),
                      static_cast<unsigned>(xml_.size()));
        return std::string(buf);
    }();
    put_string(b, gvbs::kFirstUrl, url, gvbs::kUrlSize);
    put_string(b, gvbs::kSecondUrl, url, gvbs::kUrlSize);
    gvcp::put_u32(&b[gvbs::kNumberOfInterfaces], 1);
    gvcp::put_u32(&b[gvbs::kNumberOfMessageChannels], 0);
    gvcp::put_u32(&b[gvbs::kNumberOfStreamChannels], 1);
    gvcp::put_u32(&b[gvbs::kGvcpCapability],
                  gvbs::kCapabilityWriteMem | gvbs::kCapabilityPacketResend |
                      gvbs::kCapabilitySerialNumber | gvbs::kCapabilityUserName);
    gvcp::put_u32(&b[gvbs::kTimestampTickFrequencyHigh], 0);
    gvcp::put_u32(&b[gvbs::kTimestampTickFrequencyLow], 1000000000u);  // ns ticks
    s.heartbeat_timeout_ms = std::max(kMinHeartbeatMs, config_.heartbeat_timeout_ms);
    s.scps = std::clamp(config_.packet_size, kMinPacketSize, kMaxPacketSize);
    s.width = static_cast<std::uint32_t>(config_.sensor.width);
    s.height = static_cast<std::uint32_t>(config_.sensor.height);
    s.temperature_sixteenths[0] =
        static_cast<std::int32_t>(std::lround(config_.sensor_temperature_c * 16));
    s.temperature_sixteenths[1] =
        static_cast<std::int32_t>(std::lround(config_.mainboard_temperature_c * 16));
}

GigeCamera::~GigeCamera() = default;

std::uint64_t GigeCamera::ticks_locked(Clock::time_point now) const {
    const auto d = now - state_->t0;
    return d.count() < 0 ? 0
                         : static_cast<std::uint64_t>(
                               std::chrono::duration_cast<std::chrono::nanoseconds>(d).count());
}

/// The bootstrap registers kept in the state rather than in the bootstrap memory (GigE Vision
/// 2.0, 28.1); nullopt for any other address.
std::optional<Status> GigeCamera::read_bootstrap_reg_locked(std::uint32_t a,
                                                            std::uint32_t* v) const {
    const State& s = *state_;
    switch (a) {
        case gvbs::kControlChannelPrivilege:
            *v = s.ccp;
            return Status::kSuccess;
        case gvbs::kHeartbeatTimeout:
            *v = s.heartbeat_timeout_ms;
            return Status::kSuccess;
        case gvbs::kTimestampValueHigh:
            *v = static_cast<std::uint32_t>(s.latched_ticks >> 32);
            return Status::kSuccess;
        case gvbs::kTimestampValueLow:
            *v = static_cast<std::uint32_t>(s.latched_ticks);
            return Status::kSuccess;
        case gvbs::kTimestampControl:
            return Status::kWriteProtect;  // write-only
        case gvbs::kStreamChannelPort:
            *v = s.scp;
            return Status::kSuccess;
        case gvbs::kStreamChannelPacketSize:
            *v = s.scps;
            return Status::kSuccess;
        case gvbs::kStreamChannelPacketDelay:
            *v = s.scpd;
            return Status::kSuccess;
        case gvbs::kStreamChannelDestination:
            *v = s.scda;
            return Status::kSuccess;
        case gvbs::kStreamChannelSourcePort:
            *v = s.source_port;
            return Status::kSuccess;
        case gvbs::kStreamChannelCapability:
        case gvbs::kStreamChannelConfig:
            *v = 0;
            return Status::kSuccess;
        default:
            return std::nullopt;
    }
}

/// The camera's feature registers (gige_map); nullopt for any other address.
std::optional<Status> GigeCamera::read_feature_reg_locked(std::uint32_t a, std::uint32_t* v) const {
    const State& s = *state_;
    switch (a) {
        case m::kRoiBasePointer:
            *v = m::kRoiBlock;
            return Status::kSuccess;
        case m::kRoiBlock + 0:
            *v = s.width;
            return Status::kSuccess;
        case m::kRoiBlock + 4:
            *v = s.height;
            return Status::kSuccess;
        case m::kRoiBlock + 8:
            *v = s.offset_x;
            return Status::kSuccess;
        case m::kRoiBlock + 12:
            *v = s.offset_y;
            return Status::kSuccess;
        case m::kSensorWidth:
            *v = static_cast<std::uint32_t>(config_.sensor.width);
            return Status::kSuccess;
        case m::kSensorHeight:
            *v = static_cast<std::uint32_t>(config_.sensor.height);
            return Status::kSuccess;
        case m::kPixelFormat:
            *v = s.pixel_format;
            return Status::kSuccess;
        case m::kExposureTicks:
            *v = s.exposure_ticks;
            return Status::kSuccess;
        case m::kExposureTickNs:
            *v = kExposureTickNs;
            return Status::kSuccess;
        case m::kGainSelector:
            *v = s.gain_selector;
            return Status::kSuccess;
        case m::kGainTable:
        case m::kGainTable + 4:
            *v = s.gain_centi_db[(a - m::kGainTable) / 4];
            return Status::kSuccess;
        case m::kTriggerControl:
            *v = s.trigger_control;
            return Status::kSuccess;
        case m::kTriggerSoftware:
        case m::kAcquisitionStart:
        case m::kAcquisitionStop:
            *v = 0;  // command registers read as 0 (command done)
            return Status::kSuccess;
        case m::kAcquisitionControl:
            *v = s.acquisition_control;
            return Status::kSuccess;
        case m::kFrameRate:
            *v = float_bits(s.frame_rate_hz);
            return Status::kSuccess;
        case m::kBlackLevel:
            *v = float_bits(static_cast<float>(sensor_.black_level(s.format())));
            return Status::kSuccess;
        case m::kTemperatureSelector:
            *v = s.temperature_selector;
            return Status::kSuccess;
        case m::kTemperatureTable:
        case m::kTemperatureTable + 4:
            *v = static_cast<std::uint32_t>(
                s.temperature_sixteenths[(a - m::kTemperatureTable) / 4]);
            return Status::kSuccess;
        default:
            return std::nullopt;
    }
}

Status GigeCamera::read_reg_locked(std::uint32_t a, std::uint32_t* v) const {
    const State& s = *state_;
    if (a % 4 != 0) {
        return Status::kBadAlignment;
    }
    if (auto r = read_bootstrap_reg_locked(a, v)) {
        return *r;
    }
    if (auto r = read_feature_reg_locked(a, v)) {
        return *r;
    }
    // Range checks in 64 bits: a + 4 wraps to 0 for a = 0xFFFFFFFC in 32.
    const std::uint64_t end = static_cast<std::uint64_t>(a) + 4;
    if (end <= kBootstrapSize) {
        *v = gvcp::get_u32(&s.bootstrap[a]);
        return Status::kSuccess;
    }
    if (a >= m::kXmlAddress &&
        end <= static_cast<std::uint64_t>(m::kXmlAddress) + s.xml_memory.size()) {
        *v = gvcp::get_u32(&s.xml_memory[a - m::kXmlAddress]);
        return Status::kSuccess;
    }
    if (a >= m::kFeatureBase && a < m::kFeatureEnd) {
        *v = 0;  // reserved feature space reads as zero
        return Status::kSuccess;
    }
    return Status::kInvalidAddress;
}

/// Writes to the bootstrap registers (GigE Vision 2.0, 28.1): control privilege, heartbeat,
/// timestamp, stream channel, user-defined name; nullopt for any other address.
std::optional<Status> GigeCamera::write_bootstrap_reg_locked(std::uint32_t a,
                                                             std::uint32_t v,
                                                             const HostId& from,
                                                             Clock::time_point now) {
    State& s = *state_;
    switch (a) {
        case gvbs::kControlChannelPrivilege:
            if ((v & (gvbs::kCcpControl | gvbs::kCcpExclusive)) != 0) {
                if (s.controller && *s.controller != from) {
                    return Status::kAccessDenied;
                }
                s.controller = from;
                s.ccp = v & 0x7u;
                s.last_heard = now;
                return Status::kSuccess;
            }
            if (s.controller && *s.controller != from) {
                return Status::kAccessDenied;
            }
            release_control_locked();
            return Status::kSuccess;
        case gvbs::kHeartbeatTimeout:
            if (v < kMinHeartbeatMs) {
                return Status::kInvalidParameter;
            }
            s.heartbeat_timeout_ms = v;
            return Status::kSuccess;
        case gvbs::kTimestampControl:
            if ((v & 1u) != 0) {
                s.t0 = now;
            }
            if ((v & 2u) != 0) {
                s.latched_ticks = ticks_locked(now);
            }
            return Status::kSuccess;
        case gvbs::kStreamChannelPort:
            s.scp = v & 0xFFFFu;
            return Status::kSuccess;
        case gvbs::kStreamChannelPacketSize: {
            const std::uint32_t size = v & 0xFFFFu;
            if (size < kMinPacketSize || size > kMaxPacketSize) {
                return Status::kInvalidParameter;
            }
            // Keep the size and the do-not-fragment bit; a test packet is not offered.
            s.scps = (v & 0x40000000u) | size;
            return Status::kSuccess;
        }
        case gvbs::kStreamChannelPacketDelay:
            s.scpd = v;
            return Status::kSuccess;
        case gvbs::kStreamChannelDestination:
            s.scda = v;
            return Status::kSuccess;
        case gvbs::kUserDefinedName:
        case gvbs::kUserDefinedName + 4:
        case gvbs::kUserDefinedName + 8:
        case gvbs::kUserDefinedName + 12:
            gvcp::put_u32(&s.bootstrap[a], v);
            return Status::kSuccess;
        default:
            return std::nullopt;
    }
}

/// Writes to the image-shaping feature registers (region of interest, pixel format, exposure,
/// gain, temperature selector); nullopt for any other address.
std::optional<Status> GigeCamera::write_image_reg_locked(std::uint32_t a, std::uint32_t v) {
    State& s = *state_;
    const auto roi_ok = [&](std::uint32_t w, std::uint32_t h, std::uint32_t ox, std::uint32_t oy) {
        return w >= 1 && h >= 1 &&
               static_cast<std::uint64_t>(ox) + w <=
                   static_cast<std::uint64_t>(config_.sensor.width) &&
               static_cast<std::uint64_t>(oy) + h <=
                   static_cast<std::uint64_t>(config_.sensor.height);
    };
    switch (a) {
        case m::kRoiBlock + 0:
            return roi_ok(v, s.height, s.offset_x, s.offset_y) ? (s.width = v, Status::kSuccess)
                                                               : Status::kInvalidParameter;
        case m::kRoiBlock + 4:
            return roi_ok(s.width, v, s.offset_x, s.offset_y) ? (s.height = v, Status::kSuccess)
                                                              : Status::kInvalidParameter;
        case m::kRoiBlock + 8:
            return roi_ok(s.width, s.height, v, s.offset_y) ? (s.offset_x = v, Status::kSuccess)
                                                            : Status::kInvalidParameter;
        case m::kRoiBlock + 12:
            return roi_ok(s.width, s.height, s.offset_x, v) ? (s.offset_y = v, Status::kSuccess)
                                                            : Status::kInvalidParameter;
        case m::kPixelFormat:
            if (v != devices::kPfncMono8 && v != devices::kPfncMono12 &&
                v != devices::kPfncMono16) {
                return Status::kInvalidParameter;
            }
            s.pixel_format = v;
            return Status::kSuccess;
        case m::kExposureTicks:
            if (v < 100 || v > 100000000u) {
                return Status::kInvalidParameter;
            }
            s.exposure_ticks = v;
            return Status::kSuccess;
        case m::kGainSelector:
            if (v > 1) {
                return Status::kInvalidParameter;
            }
            s.gain_selector = v;
            return Status::kSuccess;
        case m::kGainTable:
        case m::kGainTable + 4:
            if (v > 2400) {
                return Status::kInvalidParameter;
            }
            s.gain_centi_db[(a - m::kGainTable) / 4] = v;
            return Status::kSuccess;
        case m::kTemperatureSelector:
            if (v > 1) {
                return Status::kInvalidParameter;
            }
            s.temperature_selector = v;
            return Status::kSuccess;
        default:
            return std::nullopt;
    }
}

/// Writes to the acquisition feature registers (trigger, start/stop, mode, frame rate); nullopt
/// for any other address.
std::optional<Status> GigeCamera::write_acquisition_reg_locked(std::uint32_t a,
                                                               std::uint32_t v,
                                                               Clock::time_point now) {
    State& s = *state_;
    switch (a) {
        case m::kTriggerControl:
            // Selector FrameStart (0), activation RisingEdge (0) or FallingEdge (1), source
            // Software (0) or Line1 (1), mode bit.
            if ((v & ~0x00010101u) != 0) {
                return Status::kInvalidParameter;
            }
            s.trigger_control = v;
            s.triggers.clear();
            return Status::kSuccess;
        case m::kTriggerSoftware:
            if (v != 0 && s.acquiring && s.trigger_on() && s.trigger_source() == 0) {
                PendingFrame p;
                p.scene = scene_ ? scene_() : SceneState{};
                p.settings = s.settings();
                if (scene_path_) {
                    scene_path_(p.settings.exposure_us * 1e-6, &p.scene);
                }
                p.roi = {static_cast<int>(s.offset_x),
                         static_cast<int>(s.offset_y),
                         static_cast<int>(s.width),
                         static_cast<int>(s.height)};
                p.timestamp_ns = ticks_locked(now);
                s.triggers.push_back(p);
            }
            return Status::kSuccess;
        case m::kAcquisitionStart:
            if (v != 0) {
                s.acquiring = true;
                s.next_due = now;
            }
            return Status::kSuccess;
        case m::kAcquisitionStop:
            if (v != 0) {
                s.acquiring = false;
                s.triggers.clear();
            }
            return Status::kSuccess;
        case m::kAcquisitionControl: {
            const std::uint32_t mode = (v >> 8) & 0xFFu;
            if (mode > 1 || (v & ~0xFF01u) != 0) {
                return Status::kInvalidParameter;
            }
            s.acquisition_control = v;
            return Status::kSuccess;
        }
        case m::kFrameRate: {
            const float f = bits_float(v);
            if (!std::isfinite(f) || f < kMinFrameRate || f > kMaxFrameRate) {
                return Status::kInvalidParameter;
            }
            s.frame_rate_hz = f;
            return Status::kSuccess;
        }
        default:
            return std::nullopt;
    }
}

Status GigeCamera::write_reg_locked(std::uint32_t a,
                                    std::uint32_t v,
                                    const HostId& from,
                                    Clock::time_point now) {
    State& s = *state_;
    if (a % 4 != 0) {
        return Status::kBadAlignment;
    }
    // Payload-shaping registers are frozen while TLParamsLocked is set.
    const bool payload_reg = a == m::kRoiBlock || a == m::kRoiBlock + 4 || a == m::kRoiBlock + 8 ||
                             a == m::kRoiBlock + 12 || a == m::kPixelFormat ||
                             a == gvbs::kStreamChannelPacketSize;
    if (payload_reg && s.tl_locked()) {
        return Status::kAccessDenied;
    }
    if (auto r = write_bootstrap_reg_locked(a, v, from, now)) {
        return *r;
    }
    if (auto r = write_image_reg_locked(a, v)) {
        return *r;
    }
    if (auto r = write_acquisition_reg_locked(a, v, now)) {
        return *r;
    }
    std::uint32_t dummy = 0;
    // Anything else that exists is read-only.
    return read_reg_locked(a, &dummy) == Status::kSuccess ? Status::kWriteProtect
                                                          : Status::kInvalidAddress;
}

Status GigeCamera::read_mem_locked(std::uint32_t address,
                                   std::size_t count,
                                   gvcp::Bytes* out) const {
    if (address % 4 != 0 || count % 4 != 0) {
        return Status::kBadAlignment;
    }
    if (count == 0 || count > gvcp::kMaxMemData) {
        return Status::kInvalidParameter;
    }
    // A block that runs past the last address does not wrap around to address 0.
    if (static_cast<std::uint64_t>(address) + count > (std::uint64_t{1} << 32)) {
        return Status::kInvalidAddress;
    }
    out->resize(count);
    for (std::size_t i = 0; i < count; i += 4) {
        std::uint32_t v = 0;
        const Status st = read_reg_locked(address + static_cast<std::uint32_t>(i), &v);
        if (st != Status::kSuccess) {
            out->clear();
            return st;
        }
        gvcp::put_u32(out->data() + i, v);
    }
    return Status::kSuccess;
}

void GigeCamera::release_control_locked() {
    State& s = *state_;
    s.controller.reset();
    s.ccp = 0;
    // The stream channel closes and acquisition stops with the control channel.
    s.acquiring = false;
    s.triggers.clear();
    s.scp = 0;
    s.acquisition_control &= ~1u;
}

bool GigeCamera::check_heartbeat(Clock::time_point now) {
    std::lock_guard<std::mutex> lock(mutex_);
    State& s = *state_;
    if (!s.controller) {
        return false;
    }
    if (now - s.last_heard > std::chrono::milliseconds(s.heartbeat_timeout_ms)) {
        release_control_locked();
        return true;
    }
    return false;
}

/// WRITEMEM as consecutive register writes; `*written` counts the bytes accepted before the
/// first refusal.
Status GigeCamera::write_mem_locked(const gvcp::MemWrite& w,
                                    const HostId& from,
                                    Clock::time_point now,
                                    std::uint16_t* written) {
    *written = 0;
    if (w.address % 4 != 0 || w.data.size() % 4 != 0) {
        return Status::kBadAlignment;
    }
    // A block that runs past the last address does not wrap around to address 0.
    if (static_cast<std::uint64_t>(w.address) + w.data.size() > (std::uint64_t{1} << 32)) {
        return Status::kInvalidAddress;
    }
    for (std::size_t i = 0; i < w.data.size(); i += 4) {
        const Status st = write_reg_locked(
            w.address + static_cast<std::uint32_t>(i), gvcp::get_u32(&w.data[i]), from, now);
        if (st != Status::kSuccess) {
            return st;
        }
        *written = static_cast<std::uint16_t>(*written + 4);
    }
    return Status::kSuccess;
}

Status GigeCamera::read_regs_locked(const std::vector<std::uint32_t>& addresses,
                                    bool is_controller,
                                    std::vector<std::uint32_t>* values) const {
    for (std::uint32_t a : addresses) {
        std::uint32_t v = 0;
        Status st = read_reg_locked(a, &v);
        if (a == gvbs::kControlChannelPrivilege && !is_controller) {
            v = 0;  // another application reads that it holds no privilege
        }
        if (st != Status::kSuccess) {
            return st;
        }
        values->push_back(v);
    }
    return Status::kSuccess;
}

Status GigeCamera::write_regs_locked(
    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs,
    bool others_read_only,
    const HostId& from,
    Clock::time_point now,
    std::uint16_t* index) {
    *index = 0;
    for (const auto& [a, v] : pairs) {
        Status st;
        if (others_read_only && a != gvbs::kControlChannelPrivilege) {
            st = Status::kAccessDenied;
        } else {
            st = write_reg_locked(a, v, from, now);
        }
        if (st != Status::kSuccess) {
            return st;
        }
        ++*index;
    }
    return Status::kSuccess;
}

namespace {

/// The answer to a datagram that is no command: one with a valid key but an inconsistent length
/// gets INVALID_HEADER (when it asks for an acknowledge), anything else nothing.
std::optional<gvcp::Bytes> invalid_header_ack(const std::uint8_t* bytes, std::size_t size) {
    if (size >= gvcp::kHeaderSize && bytes[0] == gvcp::kKey &&
        (bytes[1] & gvcp::kFlagAckRequired) != 0) {
        gvcp::AckPacket a;
        a.status = Status::kInvalidHeader;
        a.answer = static_cast<gvcp::Command>(gvcp::get_u16(bytes + 2) + 1);
        a.ack_id = gvcp::get_u16(bytes + 6);
        return gvcp::encode(a);
    }
    return std::nullopt;
}

}  // namespace

std::optional<gvcp::Bytes> GigeCamera::handle_gvcp(const std::uint8_t* bytes,
                                                   std::size_t size,
                                                   const HostId& from,
                                                   Clock::time_point now,
                                                   std::optional<gvcp::PacketResend>* resend) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (faults_.disappeared) {
        return std::nullopt;
    }
    State& s = *state_;
    auto cmd = gvcp::parse_command(bytes, size);
    if (!cmd) {
        return invalid_header_ack(bytes, size);
    }
    const bool is_controller = s.controller && *s.controller == from;
    if (is_controller) {
        s.last_heard = now;  // every command of the primary application is a heartbeat
    }
    const bool others_excluded = s.controller && !is_controller && (s.ccp & gvbs::kCcpExclusive);
    const bool others_read_only = s.controller && !is_controller;
    const bool want_ack = (cmd->flags & gvcp::kFlagAckRequired) != 0;
    const auto reply = [&](const gvcp::AckPacket& a) -> std::optional<gvcp::Bytes> {
        if (!want_ack) {
            return std::nullopt;
        }
        return gvcp::encode(a);
    };
    const auto error_ack = [&](Status st) {
        gvcp::AckPacket a;
        a.status = st;
        a.answer = static_cast<gvcp::Command>(static_cast<std::uint16_t>(cmd->command) + 1);
        a.ack_id = cmd->req_id;
        return reply(a);
    };
    switch (cmd->command) {
        case gvcp::Command::kDiscoveryCmd:
            return gvcp::encode(gvcp::make_discovery_ack(cmd->req_id, s.bootstrap));
        case gvcp::Command::kReadRegCmd: {
            auto addrs = gvcp::parse_read_reg(*cmd);
            if (!addrs) {
                return error_ack(Status::kInvalidParameter);
            }
            if (others_excluded) {
                return error_ack(Status::kAccessDenied);
            }
            std::vector<std::uint32_t> values;
            const Status st = read_regs_locked(*addrs, is_controller, &values);
            return reply(gvcp::make_read_reg_ack(cmd->req_id, st, values));
        }
        case gvcp::Command::kWriteRegCmd: {
            auto pairs = gvcp::parse_write_reg(*cmd);
            if (!pairs) {
                return error_ack(Status::kInvalidParameter);
            }
            std::uint16_t index = 0;
            const Status st = write_regs_locked(*pairs, others_read_only, from, now, &index);
            return reply(gvcp::make_write_reg_ack(cmd->req_id, st, index));
        }
        case gvcp::Command::kReadMemCmd: {
            auto r = gvcp::parse_read_mem(*cmd);
            if (!r) {
                return error_ack(Status::kInvalidParameter);
            }
            if (others_excluded) {
                return error_ack(Status::kAccessDenied);
            }
            gvcp::Bytes data;
            const Status st = read_mem_locked(r->address, r->count, &data);
            return reply(gvcp::make_read_mem_ack(cmd->req_id, st, r->address, data));
        }
        case gvcp::Command::kWriteMemCmd: {
            auto w = gvcp::parse_write_mem(*cmd);
            if (!w) {
                return error_ack(Status::kInvalidParameter);
            }
            if (others_read_only) {
                return reply(gvcp::make_write_mem_ack(cmd->req_id, Status::kAccessDenied, 0));
            }
            std::uint16_t written = 0;
            const Status st = write_mem_locked(*w, from, now, &written);
            return reply(gvcp::make_write_mem_ack(cmd->req_id, st, written));
        }
        case gvcp::Command::kPacketResendCmd: {
            auto r = gvcp::parse_packet_resend(*cmd);
            // Hosts send it from their stream socket (not the control socket): accept it from
            // the stream destination's address.
            if (r && resend != nullptr && s.scda != 0 && from.ip == s.scda) {
                *resend = *r;
            }
            return std::nullopt;  // PACKETRESEND has no acknowledge
        }
        default:
            return error_ack(Status::kNotImplemented);
    }
}

namespace {

/// The sensor's counts as a GVSP payload: one byte a pixel, or two little-endian bytes (PFNC).
std::vector<std::uint8_t> payload_of(const cv::Mat& counts, bool one_byte) {
    std::vector<std::uint8_t> payload;
    const std::size_t n = static_cast<std::size_t>(counts.rows) * counts.cols;
    if (one_byte) {
        payload.resize(n);
        std::size_t k = 0;
        for (int y = 0; y < counts.rows; ++y) {
            const auto* row = counts.ptr<std::uint16_t>(y);
            for (int x = 0; x < counts.cols; ++x) {
                payload[k++] = static_cast<std::uint8_t>(row[x]);
            }
        }
    } else {
        // PFNC multi-byte pixels travel little-endian.
        payload.resize(2 * n);
        std::size_t k = 0;
        for (int y = 0; y < counts.rows; ++y) {
            const auto* row = counts.ptr<std::uint16_t>(y);
            if constexpr (kLittleEndianHost) {
                std::memcpy(payload.data() + k, row, 2 * static_cast<std::size_t>(counts.cols));
                k += 2 * static_cast<std::size_t>(counts.cols);
                continue;
            }
            for (int x = 0; x < counts.cols; ++x) {
                payload[k++] = static_cast<std::uint8_t>(row[x] & 0xFF);
                payload[k++] = static_cast<std::uint8_t>(row[x] >> 8);
            }
        }
    }
    return payload;
}

}  // namespace

std::optional<RenderedFrame> GigeCamera::next_frame(Clock::time_point now,
                                                    Clock::time_point* next_due) {
    PendingFrame p;
    RenderedFrame f;
    std::shared_ptr<const brdf::Brdf> brdf;
    RadianceFn renderer;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        State& s = *state_;
        if (next_due != nullptr) {
            *next_due = now + std::chrono::milliseconds(100);
        }
        if (faults_.disappeared || !s.acquiring || s.scp == 0) {
            return std::nullopt;
        }
        if (s.trigger_on()) {
            if (s.triggers.empty()) {
                return std::nullopt;
            }
            p = s.triggers.front();
            s.triggers.pop_front();
        } else {
            if (now < s.next_due) {
                if (next_due != nullptr) {
                    *next_due = s.next_due;
                }
                return std::nullopt;
            }
            const auto period = std::chrono::duration_cast<Clock::duration>(
                std::chrono::duration<double>(1.0 / s.frame_rate_hz));
            s.next_due += period;
            if (s.next_due < now) {
                s.next_due = now;  // a slow frame does not cause a burst of catch-up frames
            }
            if (next_due != nullptr) {
                *next_due = s.next_due;
            }
            p.scene = scene_ ? scene_() : SceneState{};
            p.settings = s.settings();
            if (scene_path_) {
                scene_path_(p.settings.exposure_us * 1e-6, &p.scene);
            }
            p.roi = {static_cast<int>(s.offset_x),
                     static_cast<int>(s.offset_y),
                     static_cast<int>(s.width),
                     static_cast<int>(s.height)};
            p.timestamp_ns = ticks_locked(now);
        }
        if (s.single_frame()) {
            s.acquiring = false;
        }
        s.block_id = static_cast<std::uint16_t>(s.block_id == 0xFFFF ? 1 : s.block_id + 1);
        f.block_id = s.block_id;
        ++s.frames_rendered;
        s.exposure_s_rendered += p.settings.exposure_us * 1e-6;
        brdf = brdf_;
        renderer = renderer_;
    }
    // Rendering runs outside the lock so that the control channel stays responsive; only the
    // stream thread calls next_frame, so the sensor's noise generator has a single user.
    cv::Mat radiance;
    if (!brdf) {
        radiance = cv::Mat(p.roi.height, p.roi.width, CV_32F, cv::Scalar(0));
    } else if (renderer) {
        radiance = renderer(*brdf, p.scene, config_.sensor.width, config_.sensor.height, p.roi);
        GONIO_CHECK(radiance.type() == CV_32F && radiance.rows == p.roi.height &&
                    radiance.cols == p.roi.width);
    } else {
        radiance = render_scene(*brdf, p.scene, config_.sensor.width, config_.sensor.height, p.roi);
    }
    const cv::Mat counts = sensor_.expose(radiance, p.settings);
    f.timestamp_ns = p.timestamp_ns;
    f.pixel_format = devices::pfnc_code(p.settings.format);
    f.width = p.roi.width;
    f.height = p.roi.height;
    f.offset_x = p.roi.x;
    f.offset_y = p.roi.y;
    f.settings = p.settings;
    f.payload = payload_of(counts, devices::bytes_per_pixel(p.settings.format) == 1);
    return f;
}

bool GigeCamera::line_pulse(Clock::time_point rising,
                            Clock::duration width,
                            const std::function<void(Clock::time_point, double)>& on_expose) {
    std::lock_guard<std::mutex> lock(mutex_);
    State& s = *state_;
    if (faults_.disappeared || !s.acquiring || !s.trigger_on() || s.trigger_source() != 1) {
        return false;
    }
    const Clock::time_point start = s.falling_edge() ? rising + width : rising;
    PendingFrame p;
    p.settings = s.settings();
    const double exposure_s = p.settings.exposure_us * 1e-6;
    if (on_expose) {
        on_expose(start, exposure_s);
    }
    p.scene = line_scene_ ? line_scene_(start) : SceneState{};
    if (line_path_) {
        line_path_(start, exposure_s, &p.scene);
    }
    p.roi = {static_cast<int>(s.offset_x),
             static_cast<int>(s.offset_y),
             static_cast<int>(s.width),
             static_cast<int>(s.height)};
    p.timestamp_ns = ticks_locked(start);
    s.triggers.push_back(p);
    ++s.line_frames;
    return true;
}

std::uint64_t GigeCamera::line_frames() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return state_->line_frames;
}

std::optional<StreamTarget> GigeCamera::stream_target() const {
    std::lock_guard<std::mutex> lock(mutex_);
    const State& s = *state_;
    if (s.scp == 0 || s.scda == 0) {
        return std::nullopt;
    }
    return StreamTarget{s.scda, static_cast<std::uint16_t>(s.scp), s.scps & 0xFFFFu, s.scpd};
}

bool GigeCamera::acquiring() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return state_->acquiring && state_->scp != 0 && !faults_.disappeared;
}

void GigeCamera::set_faults(const GigeFaults& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    faults_ = f;
}

bool GigeCamera::take_frame_drop() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (faults_.drop_frames <= 0) {
        return false;
    }
    --faults_.drop_frames;
    return true;
}

GigeFaults GigeCamera::faults() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return faults_;
}

void GigeCamera::set_brdf(std::shared_ptr<const brdf::Brdf> brdf) {
    std::lock_guard<std::mutex> lock(mutex_);
    brdf_ = std::move(brdf);
}

void GigeCamera::set_scene(SceneFn scene) {
    std::lock_guard<std::mutex> lock(mutex_);
    scene_ = std::move(scene);
}

void GigeCamera::set_renderer(RadianceFn renderer) {
    std::lock_guard<std::mutex> lock(mutex_);
    renderer_ = std::move(renderer);
}

void GigeCamera::set_stream_source_port(std::uint16_t port) {
    std::lock_guard<std::mutex> lock(mutex_);
    state_->source_port = port;
}

std::uint64_t GigeCamera::frames_rendered() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return state_->frames_rendered;
}

double GigeCamera::exposure_s_rendered() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return state_->exposure_s_rendered;
}

ExposureSettings GigeCamera::exposure_settings() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return state_->settings();
}

std::optional<HostId> GigeCamera::controller() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return state_->controller;
}

}  // namespace gonio::sim
