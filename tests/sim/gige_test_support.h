#pragma once

// Shared pieces of the GigE Vision tests: a simulated camera served on a loopback address of its
// own (port 3956 of 127.x.y.z, so tests run in parallel), a raw GVCP host socket, Aravis captures
// and arv-tool-0.8 runs.

#include <arpa/inet.h>
#include <arv.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/devices/gvcp.h"
#include "gonio/sim/gige_camera.h"
#include "gonio/sim/gige_server.h"

namespace gige_test {

namespace gvcp = gonio::devices::gvcp;

/// An ideal diffuser of reflectance rho (f = rho / pi).
inline std::shared_ptr<const gonio::brdf::Brdf> lambert(double rho) {
    gonio::brdf::ModelD m;
    m.diffuse = gonio::brdf::Rgbd::Constant(rho);
    return std::shared_ptr<const gonio::brdf::Brdf>(gonio::brdf::make_analytic_brdf(m));
}

/// A served camera looking at a Lambertian patch lit at theta_i from a fixed scene.
struct ServedCamera {
    std::shared_ptr<gonio::sim::GigeCamera> camera;
    std::unique_ptr<gonio::sim::GigeServer> server;
    gonio::sim::SceneState scene;

    explicit ServedCamera(gonio::sim::GigeCameraConfig cfg,
                          double rho = 0.8,
                          double theta_i = 0.5,
                          double theta_o = 0.3) {
        scene = gonio::sim::scene_from_angles(theta_i, 0.0, theta_o, 3.14159265358979, 1.0);
        const gonio::sim::SceneState s = scene;
        camera = std::make_shared<gonio::sim::GigeCamera>(cfg, lambert(rho), [s] { return s; });
        server = std::make_unique<gonio::sim::GigeServer>(camera);
        auto r = server->start_on_free_loopback();
        EXPECT_TRUE(r.has_value()) << (r ? "" : r.error().message);
    }
    ~ServedCamera() { server->stop(); }
    /// The dotted address served on (port 3956).
    std::string ip() const { return server->address().substr(std::string("gige://").size()); }
};

/// A host's GVCP socket on 127.0.0.1 (its own ephemeral port: another "application") talking to
/// the camera at `device_ip`.
class RawHost {
  public:
    explicit RawHost(const std::string& device_ip) {
        fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        sockaddr_in a{};
        a.sin_family = AF_INET;
        a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a);
        device_.sin_family = AF_INET;
        device_.sin_port = htons(gvcp::kPort);
        inet_pton(AF_INET, device_ip.c_str(), &device_.sin_addr);
    }
    ~RawHost() { close(fd_); }
    RawHost(const RawHost&) = delete;
    RawHost& operator=(const RawHost&) = delete;

    /// Sends raw bytes and returns the reply datagram (empty after 2 s without one).
    std::vector<std::uint8_t> exchange(const std::vector<std::uint8_t>& bytes) {
        sendto(fd_,
               bytes.data(),
               bytes.size(),
               0,
               reinterpret_cast<sockaddr*>(&device_),
               sizeof device_);
        pollfd p{fd_, POLLIN, 0};
        if (poll(&p, 1, 2000) <= 0) {
            return {};
        }
        std::vector<std::uint8_t> buf(2048);
        const ssize_t n = recv(fd_, buf.data(), buf.size(), 0);
        buf.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
        return buf;
    }

    gvcp::AckPacket command(const gvcp::CommandPacket& c) {
        const auto reply = exchange(gvcp::encode(c));
        auto a = gvcp::parse_ack(reply.data(), reply.size());
        EXPECT_TRUE(a.has_value()) << (a ? "" : a.error().message);
        return a ? *a : gvcp::AckPacket{gvcp::Status::kError, c.command, 0, {}};
    }

    gvcp::Status write_reg(std::uint32_t address, std::uint32_t value) {
        return command(gvcp::make_write_reg(next_id(), {{address, value}})).status;
    }

    gvcp::Status read_reg(std::uint32_t address, std::uint32_t* value) {
        const gvcp::AckPacket a = command(gvcp::make_read_reg(next_id(), {address}));
        if (a.status == gvcp::Status::kSuccess && a.data.size() == 4) {
            *value = gvcp::get_u32(a.data.data());
        }
        return a.status;
    }

    std::uint16_t next_id() { return ++id_ == 0 ? ++id_ : id_; }

  private:
    int fd_ = -1;
    sockaddr_in device_{};
    std::uint16_t id_ = 0;
};

/// Runs a command, returns its exit status and standard output (stderr merged).
struct Run {
    int status = -1;
    std::string out;
};
inline Run run(const std::string& cmd) {
    Run r;
    FILE* p = popen((cmd + " 2>&1").c_str(), "r");
    if (p == nullptr) {
        return r;
    }
    std::array<char, 4096> buf{};
    std::size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) {
        r.out.append(buf.data(), n);
    }
    r.status = pclose(p);
    return r;
}

/// The value arv-tool printed for a feature ("Width = 320 min:1 max:320" -> "320").
inline std::string arv_value(const std::string& out, const std::string& feature) {
    const std::string key = feature + " = ";
    const auto at = out.find(key);
    if (at == std::string::npos) {
        return "";
    }
    const auto start = at + key.size();
    const auto end = out.find_first_of(" \n", start);
    return out.substr(start, end - start);
}

/// Frames captured through Aravis's C API.
struct Capture {
    int complete = 0;
    int incomplete = 0;
    std::vector<std::vector<std::uint16_t>> frames;  ///< Mono16 pixels of the complete frames
    int width = 0, height = 0;
    std::string error;
};

/// Opens the camera at `ip` with Aravis, sets a Mono16 full frame and the exposure, captures `n`
/// frames (continuous acquisition at `rate_hz`).
inline Capture capture_with_aravis(
    const std::string& ip, int n, double exposure_us, double rate_hz, bool resend = true) {
    Capture c;
    GError* err = nullptr;
    ArvCamera* cam = arv_camera_new(ip.c_str(), &err);
    if (cam == nullptr) {
        c.error = err != nullptr ? err->message : "arv_camera_new failed";
        g_clear_error(&err);
        return c;
    }
    arv_camera_set_pixel_format(cam, ARV_PIXEL_FORMAT_MONO_16, &err);
    if (err == nullptr) {
        arv_camera_set_exposure_time(cam, exposure_us, &err);
    }
    if (err == nullptr) {
        arv_camera_set_gain(cam, 0.0, &err);
    }
    if (err == nullptr) {
        arv_device_set_float_feature_value(
            arv_camera_get_device(cam), "AcquisitionFrameRate", rate_hz, &err);
    }
    gint x = 0, y = 0, w = 0, h = 0;
    if (err == nullptr) {
        arv_camera_get_region(cam, &x, &y, &w, &h, &err);
    }
    ArvStream* stream = nullptr;
    if (err == nullptr) {
        stream = arv_camera_create_stream(cam, nullptr, nullptr, &err);
    }
    if (stream != nullptr && !resend) {
        g_object_set(stream, "packet-resend", ARV_GV_STREAM_PACKET_RESEND_NEVER, nullptr);
    }
    guint payload = 0;
    if (err == nullptr) {
        payload = arv_camera_get_payload(cam, &err);
    }
    if (err == nullptr) {
        for (int i = 0; i < 4; ++i) {
            arv_stream_push_buffer(stream, arv_buffer_new(payload, nullptr));
        }
        arv_camera_start_acquisition(cam, &err);
    }
    c.width = w;
    c.height = h;
    for (int i = 0; err == nullptr && i < n; ++i) {
        ArvBuffer* b = arv_stream_timeout_pop_buffer(stream, 10000000);
        if (b == nullptr) {
            ++c.incomplete;
            continue;
        }
        if (arv_buffer_get_status(b) == ARV_BUFFER_STATUS_SUCCESS) {
            ++c.complete;
            std::size_t size = 0;
            const void* data = arv_buffer_get_data(b, &size);
            std::vector<std::uint16_t> px(size / 2);
            std::memcpy(px.data(), data, px.size() * 2);
            c.frames.push_back(std::move(px));
        } else {
            ++c.incomplete;
        }
        arv_stream_push_buffer(stream, b);
    }
    if (err != nullptr) {
        c.error = err->message;
        g_clear_error(&err);
    }
    arv_camera_stop_acquisition(cam, nullptr);
    if (stream != nullptr) {
        g_object_unref(stream);
    }
    g_object_unref(cam);
    return c;
}

}  // namespace gige_test
