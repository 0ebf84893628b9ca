// USB3 Vision camera over a U3vTransport: GenCP transactions, bootstrap, manifest and GenICam XML,
// features by name, frames from the stream channel.

#include "gonio/devices/u3v_camera.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "gonio/devices/gencp.h"
#include "gonio/devices/pixel_format.h"
#include "gonio/devices/u3v_bootstrap.h"
#include "gonio/devices/u3v_stream.h"

namespace gonio::devices {

namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

std::string hex64(std::uint64_t v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "0x%llX", static_cast<unsigned long long>(v));
    return buf;
}

milliseconds remaining(Clock::time_point deadline) {
    const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now());
    return left.count() > 0 ? left : milliseconds(0);
}

std::vector<std::uint8_t> le_bytes(std::uint64_t v, std::size_t n) {
    std::vector<std::uint8_t> out(n);
    for (std::size_t i = 0; i < n; ++i) {
        out[i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFF);
    }
    return out;
}

}  // namespace

U3vCamera::U3vCamera(std::unique_ptr<U3vTransport> transport, U3vOptions options)
    : transport_(std::move(transport)), options_(options) {}

U3vCamera::~U3vCamera() {
    // Leave the device idle; errors here have nobody to report to.
    if (stream_enabled_) {
        (void)node_map_.execute("AcquisitionStop");
        (void)enable_stream(false);
    }
}

Expected<std::unique_ptr<U3vCamera>> U3vCamera::open(std::unique_ptr<U3vTransport> transport,
                                                     U3vOptions options) {
    if (!transport) {
        return make_error("U3V camera: no transport");
    }
    if (options.max_attempts < 1) {
        return make_error("U3V camera: max_attempts " + std::to_string(options.max_attempts) +
                          " < 1");
    }
    std::unique_ptr<U3vCamera> cam(new U3vCamera(std::move(transport), options));
    if (auto r = cam->bootstrap(); !r) {
        return tl::unexpected(with_context(cam->transport_->describe(), r.error()));
    }
    return cam;
}

Expected<std::vector<std::uint8_t>> U3vCamera::transact(const std::vector<std::uint8_t>& command,
                                                        std::uint16_t request_id,
                                                        std::uint16_t expected_ack,
                                                        const std::string& what) {
    ++stats_.commands;
    const milliseconds ack_timeout = std::max(options_.ack_timeout, response_time_);
    const auto hard_deadline = Clock::now() + options_.max_pending_total;
    for (int attempt = 1; attempt <= options_.max_attempts; ++attempt) {
        if (attempt > 1) {
            ++stats_.retries;
        }
        if (auto r = transport_->control_out(command, ack_timeout); !r) {
            if (transport_->last_failure() == TransportFailure::kTimeout) {
                continue;
            }
            return make_error(what + ": sending the command failed: " + r.error().message);
        }
        auto deadline = Clock::now() + ack_timeout;
        for (;;) {
            auto bytes = transport_->control_in(max_ack_len_, remaining(deadline));
            if (!bytes) {
                if (transport_->last_failure() == TransportFailure::kTimeout) {
                    break;  // retry the same request id
                }
                return make_error(what + ": " + bytes.error().message);
            }
            auto ack = gencp::decode_ack(bytes->data(), bytes->size());
            if (!ack) {
                return make_error(what + ": " + ack.error().message);
            }
            if (ack->request_id != request_id) {
                // A late acknowledge of an earlier, retried request: not ours.
                continue;
            }
            if (ack->id == gencp::CommandId::kPendingAck) {
                auto ms = gencp::parse_pending_ack(*ack);
                if (!ms) {
                    return make_error(what + ": " + ms.error().message);
                }
                ++stats_.pending_acks;
                deadline = Clock::now() + milliseconds(*ms);
                if (deadline > hard_deadline) {
                    return make_error(what + ": device kept answering PENDING_ACK beyond " +
                                      std::to_string(options_.max_pending_total.count()) + " ms");
                }
                continue;
            }
            if (static_cast<std::uint16_t>(ack->id) != expected_ack) {
                return make_error(what + ": acknowledge id " +
                                  hex64(static_cast<std::uint16_t>(ack->id)) + ", expected " +
                                  hex64(expected_ack));
            }
            if (ack->status != gencp::Status::kSuccess) {
                return make_error(what + ": " + gencp::to_string(ack->status) + " (" +
                                  hex64(static_cast<std::uint16_t>(ack->status)) + ")");
            }
            return std::move(ack->scd);
        }
        if (Clock::now() > hard_deadline) {
            break;
        }
    }
    return make_error(what + ": no acknowledge after " + std::to_string(options_.max_attempts) +
                      " attempts of " + std::to_string(ack_timeout.count()) +
                      " ms (device disconnected or not responding)");
}

Expected<std::vector<std::uint8_t>> U3vCamera::read_memory(std::uint64_t address,
                                                           std::size_t length) {
    std::vector<std::uint8_t> out;
    out.reserve(length);
    const std::size_t chunk_max = std::min<std::size_t>(max_ack_len_ - gencp::kPrefixSize, 0xFFFF);
    while (out.size() < length) {
        const auto chunk = static_cast<std::uint16_t>(std::min(chunk_max, length - out.size()));
        const std::uint64_t at = address + out.size();
        const std::uint16_t id = next_request_id_++;
        if (next_request_id_ == 0) {
            next_request_id_ = 1;
        }
        auto scd = transact(gencp::encode(gencp::make_read_mem(id, at, chunk)),
                            id,
                            static_cast<std::uint16_t>(gencp::CommandId::kReadMemAck),
                            "READMEM " + hex64(at) + " (" + std::to_string(chunk) + " bytes)");
        if (!scd) {
            return tl::unexpected(scd.error());
        }
        if (scd->size() != chunk) {
            return make_error("READMEM " + hex64(at) + ": " + std::to_string(scd->size()) +
                              " bytes returned, " + std::to_string(chunk) + " requested");
        }
        out.insert(out.end(), scd->begin(), scd->end());
    }
    return out;
}

Expected<void> U3vCamera::write_memory(std::uint64_t address,
                                       const std::vector<std::uint8_t>& data) {
    const std::size_t chunk_max = max_cmd_len_ - gencp::kPrefixSize - 8;
    std::size_t done = 0;
    do {
        const std::size_t n = std::min(chunk_max, data.size() - done);
        const std::vector<std::uint8_t> part(data.begin() + static_cast<std::ptrdiff_t>(done),
                                             data.begin() + static_cast<std::ptrdiff_t>(done + n));
        const std::uint64_t at = address + done;
        const std::uint16_t id = next_request_id_++;
        if (next_request_id_ == 0) {
            next_request_id_ = 1;
        }
        auto scd = transact(gencp::encode(gencp::make_write_mem(id, at, part)),
                            id,
                            static_cast<std::uint16_t>(gencp::CommandId::kWriteMemAck),
                            "WRITEMEM " + hex64(at) + " (" + std::to_string(n) + " bytes)");
        if (!scd) {
            return tl::unexpected(scd.error());
        }
        gencp::Ack ack;
        ack.scd = *scd;
        auto written = gencp::parse_write_mem_ack(ack);
        if (!written) {
            return make_error("WRITEMEM " + hex64(at) + ": " + written.error().message);
        }
        if (!scd->empty() && *written != n) {
            return make_error("WRITEMEM " + hex64(at) + ": device wrote " +
                              std::to_string(*written) + " of " + std::to_string(n) + " bytes");
        }
        done += n;
    } while (done < data.size());
    return {};
}

Expected<void> U3vCamera::bootstrap() {
    using namespace u3v;
    auto abrm_bytes = read_memory(0, abrm::kSize);
    if (!abrm_bytes) {
        return make_error("reading the ABRM: " + abrm_bytes.error().message);
    }
    const std::uint8_t* a = abrm_bytes->data();
    info_.vendor = get_fixed_string(a + abrm::kManufacturerName, abrm::kStringLength);
    info_.model = get_fixed_string(a + abrm::kModelName, abrm::kStringLength);
    info_.version = get_fixed_string(a + abrm::kDeviceVersion, abrm::kStringLength);
    info_.serial = get_fixed_string(a + abrm::kSerialNumber, abrm::kStringLength);
    const std::uint32_t response_ms = get_u32(a + abrm::kMaxDeviceResponseTime);
    // A device's response time is at most a few seconds; larger values are corrupt.
    if (response_ms > 0 && response_ms <= 10000) {
        response_time_ = milliseconds(response_ms);
    }
    const std::uint64_t manifest_address = get_u64(a + abrm::kManifestTableAddress);
    const std::uint64_t sbrm_address = get_u64(a + abrm::kSbrmAddress);

    auto sbrm_bytes = read_memory(sbrm_address, sbrm::kSize);
    if (!sbrm_bytes) {
        return make_error("reading the SBRM at " + hex64(sbrm_address) + ": " +
                          sbrm_bytes.error().message);
    }
    const std::uint8_t* s = sbrm_bytes->data();
    const std::uint32_t max_cmd = get_u32(s + sbrm::kMaxCommandTransferLen);
    const std::uint32_t max_ack = get_u32(s + sbrm::kMaxAckTransferLen);
    if (max_cmd < 64 || max_ack < 64) {
        return make_error("SBRM: maximum command/acknowledge transfer length " +
                          std::to_string(max_cmd) + "/" + std::to_string(max_ack) +
                          " below the 64-byte minimum");
    }
    max_cmd_len_ = std::min<std::uint32_t>(max_cmd, 65536);
    max_ack_len_ = std::min<std::uint32_t>(max_ack, 65536);
    if (get_u32(s + sbrm::kNumStreamChannels) < 1) {
        return make_error("SBRM: the device has no stream channel");
    }
    sirm_address_ = get_u64(s + sbrm::kSirmAddress);

    auto count_bytes = read_memory(manifest_address, 8);
    if (!count_bytes) {
        return make_error("reading the manifest at " + hex64(manifest_address) + ": " +
                          count_bytes.error().message);
    }
    const std::uint64_t count = get_u64(count_bytes->data());
    if (count == 0 || count > 64) {
        return make_error("manifest table at " + hex64(manifest_address) + ": entry count " +
                          std::to_string(count) + " outside [1, 64]");
    }
    auto table = read_memory(manifest_address, 8 + count * kManifestEntrySize);
    if (!table) {
        return tl::unexpected(table.error());
    }
    auto entries = decode_manifest(table->data(), table->size());
    if (!entries) {
        return tl::unexpected(entries.error());
    }
    const ManifestEntry& e = entries->front();
    if (e.size == 0 || e.size > (64u << 20)) {
        return make_error("manifest entry 0: file size " + std::to_string(e.size) +
                          " outside [1, 64 MiB]");
    }
    auto file = read_memory(e.address, e.size);
    if (!file) {
        return make_error("reading the GenICam file at " + hex64(e.address) + ": " +
                          file.error().message);
    }
    xml_zipped_ = e.zipped();
    if (xml_zipped_) {
        auto text = genicam::unzip_single_file(*file);
        if (!text) {
            return make_error("GenICam file: " + text.error().message);
        }
        xml_ = std::move(*text);
    } else {
        xml_.assign(file->begin(), file->end());
    }
    auto map = genicam::NodeMap::parse(xml_);
    if (!map) {
        return tl::unexpected(map.error());
    }
    node_map_ = std::move(*map);
    node_map_.set_port(genicam::RegisterPort{
        [this](std::uint64_t addr, std::size_t n) { return read_memory(addr, n); },
        [this](std::uint64_t addr, const std::vector<std::uint8_t>& d) {
            return write_memory(addr, d);
        }});
    for (const char* f : {"ExposureTime",
                          "PixelFormat",
                          "Width",
                          "Height",
                          "AcquisitionStart",
                          "AcquisitionStop",
                          "TriggerMode",
                          "TriggerSoftware"}) {
        if (!node_map_.has(f)) {
            return make_error("GenICam XML: required feature '" + std::string(f) + "' missing");
        }
    }
    for (const char* f : {"SensorWidth", "WidthMax"}) {
        if (node_map_.has(f)) {
            auto v = node_map_.get_int(f);
            if (!v) {
                return tl::unexpected(v.error());
            }
            info_.sensor_width = static_cast<int>(*v);
            break;
        }
    }
    for (const char* f : {"SensorHeight", "HeightMax"}) {
        if (node_map_.has(f)) {
            auto v = node_map_.get_int(f);
            if (!v) {
                return tl::unexpected(v.error());
            }
            info_.sensor_height = static_cast<int>(*v);
            break;
        }
    }
    return refresh_settings();
}

Expected<void> U3vCamera::refresh_settings() {
    auto e = node_map_.get_float("ExposureTime");
    if (!e) {
        return tl::unexpected(e.error());
    }
    exposure_us_ = *e;
    gain_ = 1;
    if (node_map_.has("Gain")) {
        auto g = node_map_.get_float("Gain");
        if (!g) {
            return tl::unexpected(g.error());
        }
        gain_ = std::pow(10.0, *g / 20.0);
    }
    black_level_ = 0;
    if (node_map_.has("BlackLevel")) {
        auto b = node_map_.get_number("BlackLevel");
        if (!b) {
            return tl::unexpected(b.error());
        }
        black_level_ = *b;
    }
    auto pf = node_map_.get_enum("PixelFormat");
    if (!pf) {
        return tl::unexpected(pf.error());
    }
    auto f = pixel_format_from_string(*pf);
    info_.bit_depth = f ? significant_bits(*f) : 0;
    auto tm = node_map_.get_enum("TriggerMode");
    if (!tm) {
        return tl::unexpected(tm.error());
    }
    trigger_mode_on_ = *tm == "On";
    return {};
}

Expected<CameraInfo> U3vCamera::info() {
    return info_;
}

Expected<void> U3vCamera::set_exposure_us(double exposure_us) {
    if (!(exposure_us > 0) || !std::isfinite(exposure_us)) {
        return make_error("exposure_us = " + std::to_string(exposure_us) + " must be > 0");
    }
    if (auto r = node_map_.set_float("ExposureTime", exposure_us); !r) {
        return r;
    }
    auto e = node_map_.get_float("ExposureTime");
    if (!e) {
        return tl::unexpected(e.error());
    }
    exposure_us_ = *e;
    return {};
}

Expected<double> U3vCamera::exposure_us() {
    auto e = node_map_.get_float("ExposureTime");
    if (e) {
        exposure_us_ = *e;
    }
    return e;
}

Expected<void> U3vCamera::set_gain(double gain) {
    if (!(gain > 0) || !std::isfinite(gain)) {
        return make_error("gain = " + std::to_string(gain) + " must be a finite factor > 0");
    }
    if (!node_map_.has("Gain")) {
        if (gain == 1) {
            return {};
        }
        return make_error("the camera has no Gain feature (only gain 1 is possible)");
    }
    if (auto r = node_map_.set_float("Gain", 20.0 * std::log10(gain)); !r) {
        return r;
    }
    return refresh_settings();
}

Expected<double> U3vCamera::gain() {
    if (auto r = refresh_settings(); !r) {
        return tl::unexpected(r.error());
    }
    return gain_;
}

Expected<void> U3vCamera::set_pixel_format(PixelFormat f) {
    if (stream_enabled_) {
        if (auto r = stop_stream(); !r) {
            return r;
        }
    }
    if (auto r = node_map_.set_enum("PixelFormat", to_string(f)); !r) {
        return r;
    }
    return refresh_settings();
}

Expected<void> U3vCamera::set_roi(const Roi& roi) {
    if (stream_enabled_) {
        if (auto r = stop_stream(); !r) {
            return r;
        }
    }
    const int w = roi.width > 0 ? roi.width : info_.sensor_width - roi.x;
    const int h = roi.height > 0 ? roi.height : info_.sensor_height - roi.y;
    if (roi.x < 0 || roi.y < 0 || w <= 0 || h <= 0) {
        return make_error("ROI x=" + std::to_string(roi.x) + " y=" + std::to_string(roi.y) + " w=" +
                          std::to_string(w) + " h=" + std::to_string(h) + " is empty or negative");
    }
    for (const char* f : {"OffsetX", "OffsetY"}) {
        if (node_map_.has(f)) {
            if (auto r = node_map_.set_int(f, 0); !r) {
                return r;
            }
        } else if ((f[6] == 'X' ? roi.x : roi.y) != 0) {
            return make_error(std::string("the camera has no ") + f + " feature");
        }
    }
    if (auto r = node_map_.set_int("Width", w); !r) {
        return r;
    }
    if (auto r = node_map_.set_int("Height", h); !r) {
        return r;
    }
    if (roi.x != 0) {
        if (auto r = node_map_.set_int("OffsetX", roi.x); !r) {
            return r;
        }
    }
    if (roi.y != 0) {
        if (auto r = node_map_.set_int("OffsetY", roi.y); !r) {
            return r;
        }
    }
    return {};
}

Expected<void> U3vCamera::configure_stream() {
    using namespace u3v;
    std::uint64_t payload = 0;
    if (node_map_.has("PayloadSize")) {
        auto p = node_map_.get_int("PayloadSize");
        if (!p) {
            return tl::unexpected(p.error());
        }
        payload = static_cast<std::uint64_t>(*p);
    } else {
        auto w = node_map_.get_int("Width");
        auto h = node_map_.get_int("Height");
        if (!w || !h) {
            return tl::unexpected(!w ? w.error() : h.error());
        }
        payload = static_cast<std::uint64_t>(*w * *h * 2);
    }
    auto req = read_memory(sirm_address_ + sirm::kRequiredPayloadSize, 16);
    if (!req) {
        return make_error("reading the SIRM at " + hex64(sirm_address_) + ": " +
                          req.error().message);
    }
    const std::uint64_t required_payload = get_u64(req->data());
    const std::uint32_t leader = get_u32(req->data() + 8);
    const std::uint32_t trailer = get_u32(req->data() + 12);
    if (required_payload != 0) {
        payload = required_payload;
    }
    payload_size_ = payload;
    const std::uint32_t size = options_.payload_transfer_size;
    transfer_size_ = size;
    transfer_count_ = static_cast<std::uint32_t>(payload / size);
    final1_size_ = static_cast<std::uint32_t>(payload % size);
    std::vector<std::uint8_t> cfg;
    put_u32(cfg, std::max<std::uint32_t>(leader, kImageLeaderSize));  // max leader size
    put_u32(cfg, transfer_size_);
    put_u32(cfg, transfer_count_);
    put_u32(cfg, final1_size_);
    put_u32(cfg, 0);  // final transfer 2
    put_u32(cfg, std::max<std::uint32_t>(trailer, kImageTrailerSize));
    return write_memory(sirm_address_ + sirm::kMaxLeaderSize, cfg);
}

Expected<void> U3vCamera::enable_stream(bool on) {
    if (auto r = write_memory(sirm_address_ + u3v::sirm::kControl, le_bytes(on ? 1 : 0, 4)); !r) {
        return r;
    }
    stream_enabled_ = on;
    if (!on) {
        transport_->stream_flush();
    }
    return {};
}

Expected<Frame> U3vCamera::receive_frame(milliseconds timeout) {
    using namespace u3v;
    const auto deadline = Clock::now() + timeout;
    Leader leader;
    for (;;) {
        auto pkt = transport_->stream_in(1024, remaining(deadline));
        if (!pkt) {
            if (transport_->last_failure() == TransportFailure::kTimeout) {
                return make_error("no frame within " + std::to_string(timeout.count()) +
                                  " ms (frame dropped or trigger lost)");
            }
            return make_error("stream channel: " + pkt.error().message);
        }
        if (!has_magic(pkt->data(), pkt->size(), kLeaderMagic)) {
            ++stats_.stray_packets;  // payload or trailer of a frame we lost: resynchronise
            continue;
        }
        auto l = decode_leader(pkt->data(), pkt->size());
        if (!l) {
            ++stats_.bad_frames;
            return tl::unexpected(l.error());
        }
        leader = *l;
        break;
    }
    const std::string block = "frame block " + std::to_string(leader.block_id);
    auto format = pixel_format_from_pfnc(leader.pixel_format);
    if (!format) {
        ++stats_.bad_frames;
        return make_error(block + ": pixel format " + hex64(leader.pixel_format) +
                          " is not Mono8, Mono12 or Mono16");
    }
    const int bpp = bytes_per_pixel(*format);
    if (leader.size_x == 0 || leader.size_y == 0 || leader.size_x > 65536 ||
        leader.size_y > 65536) {
        ++stats_.bad_frames;
        return make_error(block + ": image size " + std::to_string(leader.size_x) + " x " +
                          std::to_string(leader.size_y) + " outside [1, 65536]");
    }
    const std::uint64_t line = std::uint64_t{leader.size_x} * bpp + leader.padding_x;
    const std::uint64_t expected = line * leader.size_y;
    std::vector<std::uint8_t> payload;
    payload.reserve(expected);
    std::vector<std::uint8_t> trailer_bytes;
    const std::size_t piece_max = std::max<std::uint32_t>(transfer_size_, 1024);
    while (payload.size() < expected) {
        auto pkt = transport_->stream_in(piece_max, remaining(deadline));
        if (!pkt) {
            ++stats_.bad_frames;
            return make_error(block + ": payload incomplete (" + std::to_string(payload.size()) +
                              " of " + std::to_string(expected) +
                              " bytes): " + pkt.error().message);
        }
        if (pkt->size() == kImageTrailerSize &&
            has_magic(pkt->data(), pkt->size(), kTrailerMagic)) {
            trailer_bytes = std::move(*pkt);  // a short block: the trailer came early
            break;
        }
        if (has_magic(pkt->data(), pkt->size(), kLeaderMagic) && pkt->size() == kImageLeaderSize) {
            ++stats_.bad_frames;
            return make_error(block + ": a new leader arrived after " +
                              std::to_string(payload.size()) + " of " + std::to_string(expected) +
                              " payload bytes (trailer lost)");
        }
        payload.insert(payload.end(), pkt->begin(), pkt->end());
    }
    if (trailer_bytes.empty()) {
        auto pkt = transport_->stream_in(1024, remaining(deadline));
        if (!pkt) {
            ++stats_.bad_frames;
            return make_error(block + ": no trailer: " + pkt.error().message);
        }
        trailer_bytes = std::move(*pkt);
    }
    auto trailer = decode_trailer(trailer_bytes.data(), trailer_bytes.size());
    if (!trailer) {
        ++stats_.bad_frames;
        return make_error(block + ": " + trailer.error().message);
    }
    if (trailer->block_id != leader.block_id) {
        ++stats_.bad_frames;
        return make_error(block + ": trailer block_id " + std::to_string(trailer->block_id) +
                          " does not match the leader");
    }
    if (trailer->status != 0) {
        ++stats_.bad_frames;
        return make_error(block + ": trailer status " +
                          gencp::to_string(static_cast<gencp::Status>(trailer->status)));
    }
    if (trailer->valid_payload_size != expected || payload.size() != expected) {
        ++stats_.bad_frames;
        return make_error(block + ": payload " + std::to_string(payload.size()) +
                          " bytes, trailer valid_payload_size " +
                          std::to_string(trailer->valid_payload_size) + ", image needs " +
                          std::to_string(expected));
    }
    Frame frame;
    const int w = static_cast<int>(leader.size_x);
    const int h = static_cast<int>(leader.size_y);
    frame.image.create(h, w, CV_16U);
    for (int y = 0; y < h; ++y) {
        const std::uint8_t* src = payload.data() + static_cast<std::size_t>(y) * line;
        auto* dst = frame.image.ptr<std::uint16_t>(y);
        if (bpp == 1) {
            for (int x = 0; x < w; ++x) {
                dst[x] = src[x];
            }
        } else {
            for (int x = 0; x < w; ++x) {
                dst[x] = static_cast<std::uint16_t>(src[2 * x] | (src[2 * x + 1] << 8));
            }
        }
    }
    frame.bit_depth = significant_bits(*format);
    frame.exposure_us = exposure_us_;
    frame.gain = gain_;
    frame.timestamp_ns = static_cast<std::int64_t>(leader.timestamp_ns);
    frame.black_level = black_level_;
    frame.saturation_level = std::ldexp(1.0, frame.bit_depth) - 1;
    frame.frame_id = leader.block_id;
    frame.linear = true;
    ++stats_.frames;
    return frame;
}

Expected<Frame> U3vCamera::capture(milliseconds timeout) {
    if (streaming_) {
        return make_error("capture: a stream is running (stop_stream first)");
    }
    if (!stream_enabled_ || !trigger_mode_on_) {
        if (stream_enabled_) {
            if (auto r = stop_stream(); !r) {
                return tl::unexpected(r.error());
            }
        }
        if (auto r = node_map_.set_enum("TriggerMode", "On"); !r) {
            return tl::unexpected(r.error());
        }
        trigger_mode_on_ = true;
        if (node_map_.has("TriggerSource")) {
            if (auto r = node_map_.set_enum("TriggerSource", "Software"); !r) {
                return tl::unexpected(r.error());
            }
        }
        if (auto r = configure_stream(); !r) {
            return tl::unexpected(r.error());
        }
        if (auto r = enable_stream(true); !r) {
            return tl::unexpected(r.error());
        }
        if (auto r = node_map_.execute("AcquisitionStart"); !r) {
            return tl::unexpected(r.error());
        }
    }
    transport_->stream_flush();
    if (auto r = node_map_.execute("TriggerSoftware"); !r) {
        return tl::unexpected(r.error());
    }
    return receive_frame(timeout);
}

Expected<void> U3vCamera::start_stream() {
    if (stream_enabled_) {
        if (auto r = stop_stream(); !r) {
            return r;
        }
    }
    if (auto r = node_map_.set_enum("TriggerMode", "Off"); !r) {
        return r;
    }
    trigger_mode_on_ = false;
    if (auto r = configure_stream(); !r) {
        return r;
    }
    if (auto r = enable_stream(true); !r) {
        return r;
    }
    if (auto r = node_map_.execute("AcquisitionStart"); !r) {
        return r;
    }
    streaming_ = true;
    return {};
}

Expected<Frame> U3vCamera::next_frame(milliseconds timeout) {
    if (!streaming_) {
        return make_error("next_frame: no stream running (start_stream first)");
    }
    return receive_frame(timeout);
}

Expected<void> U3vCamera::stop_stream() {
    streaming_ = false;
    if (!stream_enabled_) {
        return {};
    }
    auto stop = node_map_.execute("AcquisitionStop");
    auto disable = enable_stream(false);
    stream_enabled_ = false;
    transport_->stream_flush();
    if (!stop) {
        return stop;
    }
    return disable;
}

}  // namespace gonio::devices
