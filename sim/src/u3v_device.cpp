// The simulated USB3 Vision camera: register space, GenCP replies, stream packets, faults.

#include "gonio/sim/u3v_device.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <deque>
#include <map>
#include <sstream>

#include "gonio/brdf/check.h"
#include "gonio/devices/camera_factory.h"
#include "gonio/devices/gencp.h"
#include "gonio/devices/genicam.h"
#include "gonio/devices/pixel_format.h"
#include "gonio/devices/u3v_bootstrap.h"
#include "gonio/devices/u3v_camera.h"
#include "gonio/devices/u3v_stream.h"
#include "gonio/sim/camera_render.h"

namespace gonio::sim {

using devices::Bytes;
using devices::PixelFormat;
namespace gencp = devices::gencp;
namespace u3v = devices::u3v;

namespace {

// Device memory map.
constexpr std::uint64_t kSbrmAddress = 0x400;
constexpr std::uint64_t kSirmAddress = 0x500;
constexpr std::uint64_t kManifestAddress = 0x800;
constexpr std::uint64_t kFeatureBase = 0x10000;
constexpr std::uint64_t kFeatureSize = 0x100;
constexpr std::uint64_t kXmlAddress = 0x100000;
constexpr std::uint32_t kMaxTransfer = 1024;

// Feature registers (offsets from kFeatureBase).
constexpr std::uint64_t kRegWidth = 0x00;
constexpr std::uint64_t kRegHeight = 0x04;
constexpr std::uint64_t kRegOffsetX = 0x08;
constexpr std::uint64_t kRegOffsetY = 0x0C;
constexpr std::uint64_t kRegWidthMax = 0x10;
constexpr std::uint64_t kRegHeightMax = 0x14;
constexpr std::uint64_t kRegPixelFormat = 0x18;
constexpr std::uint64_t kRegExposure = 0x20;    // f64, us
constexpr std::uint64_t kRegGain = 0x28;        // f64, dB
constexpr std::uint64_t kRegBlackLevel = 0x30;  // f64, counts
constexpr std::uint64_t kRegAcqStart = 0x40;
constexpr std::uint64_t kRegAcqStop = 0x44;
constexpr std::uint64_t kRegTrigger = 0x48;  // bit 0 TriggerMode, bits 8..15 TriggerSource
constexpr std::uint64_t kRegTriggerSoftware = 0x4C;
constexpr std::uint64_t kRegPayloadSize = 0x50;

constexpr double kExposureMinUs = 10;
constexpr double kExposureMaxUs = 1e7;
constexpr double kGainMaxDb = 24;

void put_at(Bytes& b, std::size_t at, std::uint64_t v, std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
        b[at + i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFF);
    }
}

void put_f64(Bytes& b, std::size_t at, double v) {
    std::uint64_t u;
    std::memcpy(&u, &v, 8);
    put_at(b, at, u, 8);
}

void put_string(Bytes& b, std::size_t at, const std::string& s) {
    const std::size_t n = std::min(s.size(), u3v::abrm::kStringLength - 1);
    std::memcpy(b.data() + at, s.data(), n);
}

std::uint64_t get_le(const Bytes& b, std::size_t n) {
    std::uint64_t v = 0;
    for (std::size_t i = n; i-- > 0;) {
        v = (v << 8) | b[i];
    }
    return v;
}

struct PendingFrame {
    SceneState scene;
    ExposureSettings settings;
    devices::Roi roi;
    std::uint64_t timestamp_ns = 0;
};

}  // namespace

struct U3vDevice::State {
    Bytes abrm = Bytes(u3v::abrm::kSize, 0);
    Bytes sbrm = Bytes(u3v::sbrm::kSize, 0);
    Bytes sirm = Bytes(u3v::sirm::kSize, 0);
    Bytes manifest;
    int width = 0, height = 0, offset_x = 0, offset_y = 0;
    PixelFormat format = PixelFormat::kMono16;
    double exposure_us = 10000;
    double gain_db = 0;
    bool trigger_on = false;
    std::uint32_t trigger_source = 0;  // 0 = Software
    bool acquiring = false;
    std::deque<PendingFrame> triggers;
    std::uint64_t block_id = 0;
    std::uint64_t frames_sent = 0;
    std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();

    std::uint64_t now_ns() const {
        return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                              std::chrono::steady_clock::now() - t0)
                                              .count());
    }
    bool stream_enabled() const {
        return (get_le(Bytes(sirm.begin() + 4, sirm.begin() + 8), 4) & 1u) != 0;
    }
    std::uint64_t payload_size() const {
        return static_cast<std::uint64_t>(width) * height * devices::bytes_per_pixel(format);
    }
};

std::string simulated_camera_xml(const U3vDeviceConfig& c) {
    std::ostringstream x;
    const auto hex = [](std::uint64_t v) {
        std::ostringstream s;
        s << "0x" << std::hex << std::uppercase << v;
        return s.str();
    };
    const auto intreg = [&](const char* name, std::uint64_t off, const char* access) {
        x << "  <IntReg Name=\"" << name << "\">\n    <Address>" << hex(kFeatureBase + off)
          << "</Address>\n    <Length>4</Length>\n    <AccessMode>" << access
          << "</AccessMode>\n    <pPort>Device</pPort>\n    <Sign>Unsigned</Sign>\n"
          << "    <Endianess>LittleEndian</Endianess>\n  </IntReg>\n";
    };
    const auto floatreg = [&](const char* name, std::uint64_t off, const char* access) {
        x << "  <FloatReg Name=\"" << name << "\">\n    <Address>" << hex(kFeatureBase + off)
          << "</Address>\n    <Length>8</Length>\n    <AccessMode>" << access
          << "</AccessMode>\n    <pPort>Device</pPort>\n"
          << "    <Endianess>LittleEndian</Endianess>\n  </FloatReg>\n";
    };
    const auto integer =
        [&](const char* name, const char* reg, const std::string& min, const std::string& max) {
            x << "  <Integer Name=\"" << name << "\">\n    <pValue>" << reg << "</pValue>\n";
            x << "    " << min << "\n    " << max << "\n    <Inc>1</Inc>\n  </Integer>\n";
        };
    const auto command = [&](const char* name, const char* reg) {
        x << "  <Command Name=\"" << name << "\">\n    <pValue>" << reg
          << "</pValue>\n    <CommandValue>1</CommandValue>\n  </Command>\n";
    };
    x << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
      << "<!-- GenICam description of the gonio simulated camera -->\n"
      << "<RegisterDescription ModelName=\"" << c.model << "\" VendorName=\"" << c.vendor
      << "\" ToolTip=\"Simulated USB3 Vision camera\" StandardNameSpace=\"None\""
      << " SchemaMajorVersion=\"1\" SchemaMinorVersion=\"1\" SchemaSubMinorVersion=\"0\""
      << " MajorVersion=\"1\" MinorVersion=\"0\" SubMinorVersion=\"0\""
      << " ProductGuid=\"0\" VersionGuid=\"0\">\n";
    x << "  <Category Name=\"Root\">\n";
    for (const char* f : {"Width",
                          "Height",
                          "OffsetX",
                          "OffsetY",
                          "WidthMax",
                          "HeightMax",
                          "SensorWidth",
                          "SensorHeight",
                          "PixelFormat",
                          "ExposureTime",
                          "Gain",
                          "BlackLevel",
                          "AcquisitionStart",
                          "AcquisitionStop",
                          "TriggerMode",
                          "TriggerSource",
                          "TriggerSoftware",
                          "PayloadSize",
                          "DeviceVendorName",
                          "DeviceModelName",
                          "DeviceSerialNumber"}) {
        x << "    <pFeature>" << f << "</pFeature>\n";
    }
    x << "  </Category>\n";
    const std::string w = std::to_string(c.sensor.width);
    const std::string h = std::to_string(c.sensor.height);
    integer("Width", "WidthReg", "<Min>1</Min>", "<pMax>WidthMaxReg</pMax>");
    integer("Height", "HeightReg", "<Min>1</Min>", "<pMax>HeightMaxReg</pMax>");
    integer("OffsetX", "OffsetXReg", "<Min>0</Min>", "<Max>" + w + "</Max>");
    integer("OffsetY", "OffsetYReg", "<Min>0</Min>", "<Max>" + h + "</Max>");
    integer("WidthMax", "WidthMaxReg", "<Min>1</Min>", "<Max>" + w + "</Max>");
    integer("HeightMax", "HeightMaxReg", "<Min>1</Min>", "<Max>" + h + "</Max>");
    integer("SensorWidth", "WidthMaxReg", "<Min>1</Min>", "<Max>" + w + "</Max>");
    integer("SensorHeight", "HeightMaxReg", "<Min>1</Min>", "<Max>" + h + "</Max>");
    integer("PayloadSize", "PayloadSizeReg", "<Min>0</Min>", "<Max>4294967295</Max>");
    intreg("WidthReg", kRegWidth, "RW");
    intreg("HeightReg", kRegHeight, "RW");
    intreg("OffsetXReg", kRegOffsetX, "RW");
    intreg("OffsetYReg", kRegOffsetY, "RW");
    intreg("WidthMaxReg", kRegWidthMax, "RO");
    intreg("HeightMaxReg", kRegHeightMax, "RO");
    intreg("PayloadSizeReg", kRegPayloadSize, "RO");
    x << "  <Enumeration Name=\"PixelFormat\">\n";
    for (PixelFormat f : {PixelFormat::kMono8, PixelFormat::kMono12, PixelFormat::kMono16}) {
        x << "    <EnumEntry Name=\"" << devices::to_string(f) << "\">\n      <Value>"
          << hex(devices::pfnc_code(f)) << "</Value>\n    </EnumEntry>\n";
    }
    x << "    <pValue>PixelFormatReg</pValue>\n  </Enumeration>\n";
    intreg("PixelFormatReg", kRegPixelFormat, "RW");
    x << "  <Float Name=\"ExposureTime\">\n    <pValue>ExposureTimeReg</pValue>\n"
      << "    <Min>" << kExposureMinUs << "</Min>\n    <Max>" << kExposureMaxUs
      << "</Max>\n    <Unit>us</Unit>\n  </Float>\n";
    floatreg("ExposureTimeReg", kRegExposure, "RW");
    x << "  <Float Name=\"Gain\">\n    <pValue>GainReg</pValue>\n    <Min>0</Min>\n    <Max>"
      << kGainMaxDb << "</Max>\n    <Unit>dB</Unit>\n  </Float>\n";
    floatreg("GainReg", kRegGain, "RW");
    x << "  <Float Name=\"BlackLevel\">\n    <pValue>BlackLevelReg</pValue>\n"
      << "    <Unit>DN</Unit>\n  </Float>\n";
    floatreg("BlackLevelReg", kRegBlackLevel, "RO");
    command("AcquisitionStart", "AcquisitionStartReg");
    command("AcquisitionStop", "AcquisitionStopReg");
    command("TriggerSoftware", "TriggerSoftwareReg");
    intreg("AcquisitionStartReg", kRegAcqStart, "WO");
    intreg("AcquisitionStopReg", kRegAcqStop, "WO");
    intreg("TriggerSoftwareReg", kRegTriggerSoftware, "WO");
    x << "  <Enumeration Name=\"TriggerMode\">\n"
      << "    <EnumEntry Name=\"Off\">\n      <Value>0</Value>\n    </EnumEntry>\n"
      << "    <EnumEntry Name=\"On\">\n      <Value>1</Value>\n    </EnumEntry>\n"
      << "    <pValue>TriggerModeReg</pValue>\n  </Enumeration>\n";
    x << "  <MaskedIntReg Name=\"TriggerModeReg\">\n    <Address>"
      << hex(kFeatureBase + kRegTrigger) << "</Address>\n    <Length>4</Length>\n"
      << "    <AccessMode>RW</AccessMode>\n    <pPort>Device</pPort>\n    <Bit>0</Bit>\n"
      << "    <Endianess>LittleEndian</Endianess>\n  </MaskedIntReg>\n";
    x << "  <Enumeration Name=\"TriggerSource\">\n"
      << "    <EnumEntry Name=\"Software\">\n      <Value>0</Value>\n    </EnumEntry>\n"
      << "    <pValue>TriggerSourceReg</pValue>\n  </Enumeration>\n";
    x << "  <MaskedIntReg Name=\"TriggerSourceReg\">\n    <Address>"
      << hex(kFeatureBase + kRegTrigger) << "</Address>\n    <Length>4</Length>\n"
      << "    <AccessMode>RW</AccessMode>\n    <pPort>Device</pPort>\n    <LSB>8</LSB>\n"
      << "    <MSB>15</MSB>\n    <Endianess>LittleEndian</Endianess>\n  </MaskedIntReg>\n";
    const auto strreg = [&](const char* feature, std::uint64_t address) {
        x << "  <StringReg Name=\"" << feature << "\">\n    <Address>" << hex(address)
          << "</Address>\n    <Length>64</Length>\n    <AccessMode>RO</AccessMode>\n"
          << "    <pPort>Device</pPort>\n  </StringReg>\n";
    };
    strreg("DeviceVendorName", u3v::abrm::kManufacturerName);
    strreg("DeviceModelName", u3v::abrm::kModelName);
    strreg("DeviceSerialNumber", u3v::abrm::kSerialNumber);
    x << "  <Port Name=\"Device\"/>\n</RegisterDescription>\n";
    return x.str();
}

U3vDevice::U3vDevice(U3vDeviceConfig config, std::shared_ptr<const brdf::Brdf> brdf, SceneFn scene)
    : config_(std::move(config)),
      brdf_(std::move(brdf)),
      scene_(std::move(scene)),
      state_(std::make_unique<State>()),
      sensor_(config_.sensor) {
    xml_ = simulated_camera_xml(config_);
    if (config_.zipped_xml) {
        auto z = devices::genicam::zip_single_file("SimCam.xml", xml_);
        GONIO_CHECK_MSG(z.has_value(), "zipping the simulated camera XML failed");
        xml_file_ = std::move(*z);
    } else {
        xml_file_.assign(xml_.begin(), xml_.end());
    }
    State& s = *state_;
    s.width = config_.sensor.width;
    s.height = config_.sensor.height;
    namespace abrm = u3v::abrm;
    put_at(s.abrm, abrm::kGencpVersion, 0x00010000, 4);  // GenCP 1.0
    put_string(s.abrm, abrm::kManufacturerName, config_.vendor);
    put_string(s.abrm, abrm::kModelName, config_.model);
    put_string(s.abrm, abrm::kFamilyName, "gonio simulated");
    put_string(s.abrm, abrm::kDeviceVersion, "1.0");
    put_string(s.abrm, abrm::kManufacturerInfo, "renders a ground-truth BRDF");
    put_string(s.abrm, abrm::kSerialNumber, config_.serial);
    put_at(s.abrm, abrm::kMaxDeviceResponseTime, config_.response_time_ms, 4);
    put_at(s.abrm, abrm::kManifestTableAddress, kManifestAddress, 8);
    put_at(s.abrm, abrm::kSbrmAddress, kSbrmAddress, 8);
    namespace sbrm = u3v::sbrm;
    put_at(s.sbrm, sbrm::kU3vVersion, 0x00010000, 4);
    put_at(s.sbrm, sbrm::kMaxCommandTransferLen, kMaxTransfer, 4);
    put_at(s.sbrm, sbrm::kMaxAckTransferLen, kMaxTransfer, 4);
    put_at(s.sbrm, sbrm::kNumStreamChannels, 1, 4);
    put_at(s.sbrm, sbrm::kSirmAddress, kSirmAddress, 8);
    put_at(s.sbrm, sbrm::kSirmLength, u3v::sirm::kSize, 4);
    put_at(s.sbrm, sbrm::kCurrentSpeed, 4, 4);  // SuperSpeed
    u3v::ManifestEntry e;
    e.file_version = 0x01000000;
    e.schema = (1u << 24) | (1u << 16) | (config_.zipped_xml ? u3v::kSchemaZip : 0);
    e.address = kXmlAddress;
    e.size = xml_file_.size();
    s.manifest = u3v::encode_manifest({e});
}

U3vDevice::~U3vDevice() = default;

void U3vDevice::set_faults(const U3vFaults& f) {
    std::lock_guard<std::mutex> lock(mutex_);
    faults_ = f;
}

U3vFaults U3vDevice::faults() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return faults_;
}

void U3vDevice::set_brdf(std::shared_ptr<const brdf::Brdf> brdf) {
    std::lock_guard<std::mutex> lock(mutex_);
    brdf_ = std::move(brdf);
}

void U3vDevice::set_scene(SceneFn scene) {
    std::lock_guard<std::mutex> lock(mutex_);
    scene_ = std::move(scene);
}

std::uint64_t U3vDevice::frames_sent() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return state_->frames_sent;
}

ExposureSettings U3vDevice::exposure_settings() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return ExposureSettings{
        state_->exposure_us, std::pow(10.0, state_->gain_db / 20.0), state_->format};
}

bool U3vDevice::streaming_continuous() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return state_->acquiring && !state_->trigger_on && state_->stream_enabled();
}

Bytes U3vDevice::read_mem(std::uint64_t address, std::size_t length, std::uint16_t* status) {
    State& s = *state_;
    *status = static_cast<std::uint16_t>(gencp::Status::kSuccess);
    const auto slice = [&](const Bytes& region, std::uint64_t base) -> Bytes {
        if (address < base || address + length > base + region.size()) {
            *status = static_cast<std::uint16_t>(gencp::Status::kInvalidAddress);
            return {};
        }
        const auto* p = region.data() + (address - base);
        return Bytes(p, p + length);
    };
    if (address < u3v::abrm::kSize) {
        put_at(s.abrm, u3v::abrm::kTimestamp, s.now_ns(), 8);
        return slice(s.abrm, 0);
    }
    if (address >= kSbrmAddress && address < kSbrmAddress + u3v::sbrm::kSize) {
        return slice(s.sbrm, kSbrmAddress);
    }
    if (address >= kSirmAddress && address < kSirmAddress + u3v::sirm::kSize) {
        put_at(s.sirm, u3v::sirm::kRequiredPayloadSize, s.payload_size(), 8);
        put_at(s.sirm, u3v::sirm::kRequiredLeaderSize, u3v::kImageLeaderSize, 4);
        put_at(s.sirm, u3v::sirm::kRequiredTrailerSize, u3v::kImageTrailerSize, 4);
        return slice(s.sirm, kSirmAddress);
    }
    if (address >= kManifestAddress && address < kManifestAddress + s.manifest.size()) {
        return slice(s.manifest, kManifestAddress);
    }
    if (address >= kFeatureBase && address < kFeatureBase + kFeatureSize) {
        Bytes f(kFeatureSize, 0);
        put_at(f, kRegWidth, static_cast<std::uint64_t>(s.width), 4);
        put_at(f, kRegHeight, static_cast<std::uint64_t>(s.height), 4);
        put_at(f, kRegOffsetX, static_cast<std::uint64_t>(s.offset_x), 4);
        put_at(f, kRegOffsetY, static_cast<std::uint64_t>(s.offset_y), 4);
        put_at(f, kRegWidthMax, static_cast<std::uint64_t>(config_.sensor.width), 4);
        put_at(f, kRegHeightMax, static_cast<std::uint64_t>(config_.sensor.height), 4);
        put_at(f, kRegPixelFormat, devices::pfnc_code(s.format), 4);
        put_f64(f, kRegExposure, s.exposure_us);
        put_f64(f, kRegGain, s.gain_db);
        put_f64(f, kRegBlackLevel, sensor_.black_level(s.format));
        put_at(f, kRegTrigger, (s.trigger_on ? 1u : 0u) | (s.trigger_source << 8), 4);
        put_at(f, kRegPayloadSize, s.payload_size(), 4);
        return slice(f, kFeatureBase);
    }
    if (address >= kXmlAddress && address < kXmlAddress + xml_file_.size()) {
        return slice(xml_file_, kXmlAddress);
    }
    *status = static_cast<std::uint16_t>(gencp::Status::kInvalidAddress);
    return {};
}

std::uint16_t U3vDevice::write_mem(std::uint64_t address, const Bytes& data) {
    State& s = *state_;
    using gencp::Status;
    const auto st = [](Status x) { return static_cast<std::uint16_t>(x); };
    // SIRM: the host-written part (stream control and transfer sizes).
    if (address >= kSirmAddress && address < kSirmAddress + u3v::sirm::kSize) {
        const std::uint64_t off = address - kSirmAddress;
        if (off + data.size() > u3v::sirm::kSize) {
            return st(Status::kInvalidAddress);
        }
        const bool control = off == u3v::sirm::kControl && data.size() == 4;
        if (!control && off < u3v::sirm::kMaxLeaderSize) {
            return st(Status::kWriteProtect);
        }
        std::copy(data.begin(), data.end(), s.sirm.begin() + static_cast<std::ptrdiff_t>(off));
        if (control && !s.stream_enabled()) {
            s.triggers.clear();
        }
        return st(Status::kSuccess);
    }
    if (address < kFeatureBase || address >= kFeatureBase + kFeatureSize) {
        // Bootstrap, manifest and XML are read-only here.
        if (address < kXmlAddress + xml_file_.size()) {
            return st(Status::kWriteProtect);
        }
        return st(Status::kInvalidAddress);
    }
    const std::uint64_t reg = address - kFeatureBase;
    const bool tl_locked = s.acquiring;
    if (reg == kRegExposure || reg == kRegGain) {
        if (data.size() != 8) {
            return st(Status::kInvalidParameter);
        }
        double v;
        const std::uint64_t u = get_le(data, 8);
        std::memcpy(&v, &u, 8);
        if (reg == kRegExposure) {
            if (!(v >= kExposureMinUs && v <= kExposureMaxUs)) {
                return st(Status::kInvalidParameter);
            }
            s.exposure_us = v;
        } else {
            if (!(v >= 0 && v <= kGainMaxDb)) {
                return st(Status::kInvalidParameter);
            }
            s.gain_db = v;
        }
        return st(Status::kSuccess);
    }
    if (data.size() != 4) {
        return st(reg < kFeatureSize ? Status::kInvalidParameter : Status::kInvalidAddress);
    }
    const std::uint32_t v = static_cast<std::uint32_t>(get_le(data, 4));
    switch (reg) {
        case kRegWidth:
        case kRegHeight:
        case kRegOffsetX:
        case kRegOffsetY: {
            // Image size is locked while acquiring (as the transport-layer parameters are).
            if (tl_locked) {
                return st(Status::kAccessDenied);
            }
            int w = s.width, h = s.height, x = s.offset_x, y = s.offset_y;
            (reg == kRegWidth     ? w
             : reg == kRegHeight  ? h
             : reg == kRegOffsetX ? x
                                  : y) = static_cast<int>(v);
            if (w < 1 || h < 1 || x + w > config_.sensor.width || y + h > config_.sensor.height) {
                return st(Status::kInvalidParameter);
            }
            s.width = w;
            s.height = h;
            s.offset_x = x;
            s.offset_y = y;
            return st(Status::kSuccess);
        }
        case kRegPixelFormat: {
            if (tl_locked) {
                return st(Status::kAccessDenied);
            }
            auto f = devices::pixel_format_from_pfnc(v);
            if (!f) {
                return st(Status::kInvalidParameter);
            }
            s.format = *f;
            return st(Status::kSuccess);
        }
        case kRegTrigger:
            // Bit 0 is TriggerMode; TriggerSource (bits 8..15) has the single entry Software = 0.
            if ((v & ~0x1u) != 0) {
                return st(Status::kInvalidParameter);
            }
            s.trigger_on = (v & 1u) != 0;
            s.trigger_source = v >> 8;
            return st(Status::kSuccess);
        case kRegAcqStart:
            if (v == 1) {
                s.acquiring = true;
            }
            return st(Status::kSuccess);
        case kRegAcqStop:
            if (v == 1) {
                s.acquiring = false;
                s.triggers.clear();
            }
            return st(Status::kSuccess);
        case kRegTriggerSoftware: {
            if (v != 1) {
                return st(Status::kSuccess);
            }
            // A trigger outside triggered acquisition is refused, as the host would otherwise
            // wait for a frame that never comes.
            if (!s.acquiring || !s.trigger_on || !s.stream_enabled()) {
                return st(Status::kWrongConfig);
            }
            if (s.triggers.size() >= 16) {
                return st(Status::kBusy);
            }
            PendingFrame p;
            p.scene = scene_ ? scene_() : SceneState{};
            p.settings = {s.exposure_us, std::pow(10.0, s.gain_db / 20.0), s.format};
            p.roi = {s.offset_x, s.offset_y, s.width, s.height};
            p.timestamp_ns = s.now_ns();
            s.triggers.push_back(p);
            return st(Status::kSuccess);
        }
        default:
            return st(reg == kRegWidthMax || reg == kRegHeightMax || reg == kRegPayloadSize
                          ? Status::kWriteProtect
                          : Status::kInvalidAddress);
    }
}

std::vector<Bytes> U3vDevice::handle_control(const Bytes& command) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (faults_.disappeared) {
        return {};
    }
    auto cmd = gencp::decode_command(command.data(), command.size());
    if (!cmd) {
        // An unparseable prefix: answer with INVALID_HEADER if a request id can be read.
        if (command.size() >= gencp::kPrefixSize) {
            gencp::Ack a;
            a.status = gencp::Status::kInvalidHeader;
            a.id = gencp::CommandId::kReadMemAck;
            a.request_id = u3v::get_u16(command.data() + 10);
            return {gencp::encode(a)};
        }
        return {};
    }
    if (faults_.lose_acks > 0) {
        --faults_.lose_acks;
        return {};
    }
    std::vector<Bytes> out;
    if (faults_.never_answer_after_pending > 0) {
        --faults_.never_answer_after_pending;
        out.push_back(gencp::encode(gencp::make_pending_ack(cmd->request_id, faults_.pending_ms)));
        return out;
    }
    if (faults_.pending_acks > 0) {
        --faults_.pending_acks;
        out.push_back(gencp::encode(gencp::make_pending_ack(cmd->request_id, faults_.pending_ms)));
    }
    std::uint16_t status = 0;
    if (cmd->id == gencp::CommandId::kReadMemCmd) {
        auto req = gencp::parse_read_mem(*cmd);
        if (!req) {
            out.push_back(gencp::encode(
                gencp::make_read_mem_ack(cmd->request_id, gencp::Status::kInvalidParameter, {})));
            return out;
        }
        if (req->length + gencp::kPrefixSize > kMaxTransfer) {
            out.push_back(gencp::encode(
                gencp::make_read_mem_ack(cmd->request_id, gencp::Status::kInvalidParameter, {})));
            return out;
        }
        Bytes data = read_mem(req->address, req->length, &status);
        out.push_back(gencp::encode(gencp::make_read_mem_ack(
            cmd->request_id, static_cast<gencp::Status>(status), std::move(data))));
        return out;
    }
    if (cmd->id == gencp::CommandId::kWriteMemCmd) {
        auto req = gencp::parse_write_mem(*cmd);
        if (!req) {
            out.push_back(gencp::encode(
                gencp::make_write_mem_ack(cmd->request_id, gencp::Status::kInvalidParameter, 0)));
            return out;
        }
        status = write_mem(req->address, req->data);
        out.push_back(gencp::encode(gencp::make_write_mem_ack(
            cmd->request_id,
            static_cast<gencp::Status>(status),
            status == 0 ? static_cast<std::uint16_t>(req->data.size()) : 0)));
        return out;
    }
    gencp::Ack a;
    a.status = gencp::Status::kNotImplemented;
    a.id = static_cast<gencp::CommandId>(static_cast<std::uint16_t>(cmd->id) | 1u);
    a.request_id = cmd->request_id;
    out.push_back(gencp::encode(a));
    return out;
}

std::vector<Bytes> U3vDevice::poll_stream() {
    std::lock_guard<std::mutex> lock(mutex_);
    return render_frame_locked();
}

std::vector<Bytes> U3vDevice::render_frame_locked() {
    State& s = *state_;
    if (faults_.disappeared || !s.acquiring || !s.stream_enabled()) {
        return {};
    }
    PendingFrame p;
    if (s.trigger_on) {
        if (s.triggers.empty()) {
            return {};
        }
        p = s.triggers.front();
        s.triggers.pop_front();
    } else {
        p.scene = scene_ ? scene_() : SceneState{};
        p.settings = {s.exposure_us, std::pow(10.0, s.gain_db / 20.0), s.format};
        p.roi = {s.offset_x, s.offset_y, s.width, s.height};
        p.timestamp_ns = s.now_ns();
    }
    const std::uint64_t block = ++s.block_id;
    if (faults_.drop_frames > 0) {
        --faults_.drop_frames;
        return {};
    }
    cv::Mat radiance;
    if (brdf_) {
        radiance =
            render_scene(*brdf_, p.scene, config_.sensor.width, config_.sensor.height, p.roi);
    } else {
        radiance = cv::Mat(p.roi.height, p.roi.width, CV_32F, cv::Scalar(0));
    }
    const cv::Mat counts = sensor_.expose(radiance, p.settings);
    const int bpp = devices::bytes_per_pixel(p.settings.format);
    Bytes payload(static_cast<std::size_t>(counts.rows) * counts.cols * bpp);
    std::size_t k = 0;
    for (int y = 0; y < counts.rows; ++y) {
        const auto* row = counts.ptr<std::uint16_t>(y);
        for (int x = 0; x < counts.cols; ++x) {
            payload[k++] = static_cast<std::uint8_t>(row[x] & 0xFF);
            if (bpp == 2) {
                payload[k++] = static_cast<std::uint8_t>(row[x] >> 8);
            }
        }
    }
    std::vector<Bytes> out;
    u3v::Leader l;
    l.block_id = block;
    l.timestamp_ns = p.timestamp_ns;
    l.pixel_format = devices::pfnc_code(p.settings.format);
    l.size_x = static_cast<std::uint32_t>(p.roi.width);
    l.size_y = static_cast<std::uint32_t>(p.roi.height);
    l.offset_x = static_cast<std::uint32_t>(p.roi.x);
    l.offset_y = static_cast<std::uint32_t>(p.roi.y);
    out.push_back(u3v::encode(l));
    // Payload in the transfer sizes the host programmed (one piece if it programmed none).
    const std::size_t piece =
        std::max<std::size_t>(1024,
                              get_le(Bytes(s.sirm.begin() + u3v::sirm::kPayloadTransferSize,
                                           s.sirm.begin() + u3v::sirm::kPayloadTransferSize + 4),
                                     4));
    for (std::size_t at = 0; at < payload.size(); at += piece) {
        const std::size_t n = std::min(piece, payload.size() - at);
        out.emplace_back(payload.begin() + static_cast<std::ptrdiff_t>(at),
                         payload.begin() + static_cast<std::ptrdiff_t>(at + n));
    }
    u3v::Trailer t;
    t.block_id = block;
    t.status = 0;
    t.valid_payload_size = payload.size();
    t.size_y = l.size_y;
    Bytes trailer = u3v::encode(t);
    if (faults_.corrupt_trailers > 0) {
        --faults_.corrupt_trailers;
        trailer[0] ^= 0xFF;
    }
    out.push_back(std::move(trailer));
    ++s.frames_sent;
    return out;
}

namespace {

class MemoryTransport : public devices::U3vTransport {
  public:
    explicit MemoryTransport(std::shared_ptr<U3vDevice> d) : device_(std::move(d)) {}

    Expected<void> control_out(const Bytes& bytes, std::chrono::milliseconds) override {
        for (Bytes& a : device_->handle_control(bytes)) {
            control_.push_back(std::move(a));
        }
        return {};
    }

    Expected<Bytes> control_in(std::size_t max_bytes, std::chrono::milliseconds) override {
        if (control_.empty()) {
            failure_ = devices::TransportFailure::kTimeout;
            return make_error("u3v-mem: no acknowledge pending");
        }
        return pop(control_, max_bytes);
    }

    Expected<Bytes> stream_in(std::size_t max_bytes, std::chrono::milliseconds) override {
        if (stream_.empty()) {
            for (Bytes& b : device_->poll_stream()) {
                stream_.push_back(std::move(b));
            }
        }
        if (stream_.empty()) {
            failure_ = devices::TransportFailure::kTimeout;
            return make_error("u3v-mem: no stream transfer pending");
        }
        return pop(stream_, max_bytes);
    }

    void stream_flush() override { stream_.clear(); }
    devices::TransportFailure last_failure() const override { return failure_; }
    std::string describe() const override { return "u3v-mem:" + device_->config().serial; }

  private:
    Expected<Bytes> pop(std::deque<Bytes>& q, std::size_t max_bytes) {
        Bytes b = std::move(q.front());
        q.pop_front();
        if (b.size() > max_bytes) {
            failure_ = devices::TransportFailure::kOther;
            return make_error("u3v-mem: transfer of " + std::to_string(b.size()) +
                              " bytes overflows the " + std::to_string(max_bytes) + "-byte buffer");
        }
        return b;
    }

    std::shared_ptr<U3vDevice> device_;
    std::deque<Bytes> control_;
    std::deque<Bytes> stream_;
    devices::TransportFailure failure_ = devices::TransportFailure::kOther;
};

std::mutex& mem_registry_mutex() {
    static std::mutex m;
    return m;
}

std::map<std::string, std::weak_ptr<U3vDevice>>& mem_registry() {
    static std::map<std::string, std::weak_ptr<U3vDevice>> r;
    return r;
}

}  // namespace

std::unique_ptr<devices::U3vTransport> make_memory_transport(std::shared_ptr<U3vDevice> device) {
    return std::make_unique<MemoryTransport>(std::move(device));
}

void register_in_process_camera(const std::string& name, std::shared_ptr<U3vDevice> device) {
    {
        std::lock_guard<std::mutex> lock(mem_registry_mutex());
        mem_registry()[name] = device;
    }
    devices::register_camera_scheme(
        "u3v-mem", [](const std::string& rest) -> Expected<std::unique_ptr<devices::Camera>> {
            std::shared_ptr<U3vDevice> d;
            {
                std::lock_guard<std::mutex> lock(mem_registry_mutex());
                auto it = mem_registry().find(rest);
                if (it != mem_registry().end()) {
                    d = it->second.lock();
                }
            }
            if (!d) {
                return make_error("u3v-mem:" + rest + ": no simulated camera registered under '" +
                                  rest + "'");
            }
            auto cam = devices::U3vCamera::open(make_memory_transport(d));
            if (!cam) {
                return tl::unexpected(cam.error());
            }
            return std::unique_ptr<devices::Camera>(std::move(*cam));
        });
}

}  // namespace gonio::sim
