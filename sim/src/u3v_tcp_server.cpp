// Serving a simulated U3V device over TCP on 127.0.0.1 (framing of devices/u3v_tcp.h).

#include "gonio/sim/u3v_tcp_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "gonio/devices/u3v_bootstrap.h"
#include "gonio/devices/u3v_tcp.h"

namespace gonio::sim {

using devices::Bytes;

U3vTcpServer::U3vTcpServer(std::shared_ptr<U3vDevice> device) : device_(std::move(device)) {}

U3vTcpServer::~U3vTcpServer() {
    stop();
}

Expected<void> U3vTcpServer::start(std::uint16_t port) {
    if (thread_.joinable()) {
        return make_error("U3V TCP server: already started on port " + std::to_string(port_));
    }
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (listen_fd_ < 0) {
        return make_error(std::string("U3V TCP server: socket: ") + std::strerror(errno));
    }
    const int one = 1;
    ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
        ::listen(listen_fd_, 4) != 0) {
        const int err = errno;
        ::close(listen_fd_);
        listen_fd_ = -1;
        return make_error("U3V TCP server: bind/listen on 127.0.0.1:" + std::to_string(port) +
                          ": " + std::strerror(err));
    }
    socklen_t len = sizeof addr;
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    if (::pipe2(wake_pipe_, O_CLOEXEC) != 0) {
        ::close(listen_fd_);
        listen_fd_ = -1;
        return make_error(std::string("U3V TCP server: pipe: ") + std::strerror(errno));
    }
    stop_ = false;
    thread_ = std::thread([this] { run(); });
    return {};
}

void U3vTcpServer::stop() {
    if (!thread_.joinable()) {
        return;
    }
    stop_ = true;
    const char c = 1;
    (void)!::write(wake_pipe_[1], &c, 1);
    thread_.join();
    ::close(listen_fd_);
    ::close(wake_pipe_[0]);
    ::close(wake_pipe_[1]);
    listen_fd_ = wake_pipe_[0] = wake_pipe_[1] = -1;
}

std::string U3vTcpServer::address() const {
    return "u3v-tcp://127.0.0.1:" + std::to_string(port_);
}

void U3vTcpServer::run() {
    while (!stop_) {
        pollfd p[2] = {{listen_fd_, POLLIN, 0}, {wake_pipe_[0], POLLIN, 0}};
        if (::poll(p, 2, -1) < 0 && errno != EINTR) {
            return;
        }
        if (stop_ || (p[1].revents & POLLIN)) {
            return;
        }
        if (p[0].revents & POLLIN) {
            const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
            if (fd < 0) {
                continue;
            }
            if (device_->faults().disappeared) {
                ::close(fd);  // a vanished device accepts nobody
                continue;
            }
            const int one = 1;
            ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
            serve_client(fd);
            ::close(fd);
        }
    }
}

namespace {

bool send_all(int fd, const std::uint8_t* data, std::size_t n) {
    while (n > 0) {
        const ssize_t k = ::send(fd, data, n, MSG_NOSIGNAL);
        if (k < 0 && errno == EINTR) {
            continue;
        }
        if (k <= 0) {
            return false;
        }
        data += k;
        n -= static_cast<std::size_t>(k);
    }
    return true;
}

bool send_frame(int fd, std::uint8_t channel, const Bytes& b) {
    const Bytes h = devices::encode_tcp_frame_header(channel, static_cast<std::uint32_t>(b.size()));
    return send_all(fd, h.data(), h.size()) && send_all(fd, b.data(), b.size());
}

}  // namespace

void U3vTcpServer::serve_client(int fd) {
    using Clock = std::chrono::steady_clock;
    Bytes in;
    auto next_continuous = Clock::now();
    while (!stop_) {
        if (device_->faults().disappeared) {
            return;  // closing the socket is what the host sees of an unplugged device
        }
        int timeout_ms = 50;
        const bool continuous = device_->streaming_continuous();
        if (continuous) {
            const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(
                next_continuous - Clock::now());
            timeout_ms = static_cast<int>(std::max<long long>(0, wait.count()));
        }
        pollfd p[2] = {{fd, POLLIN, 0}, {wake_pipe_[0], POLLIN, 0}};
        const int rc = ::poll(p, 2, timeout_ms);
        if (rc < 0 && errno != EINTR) {
            return;
        }
        if (p[1].revents & POLLIN) {
            return;
        }
        if (p[0].revents & (POLLIN | POLLHUP | POLLERR)) {
            std::uint8_t buf[1 << 16];
            const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
            if (n <= 0) {
                return;  // host closed
            }
            in.insert(in.end(), buf, buf + n);
            std::size_t at = 0;
            while (in.size() - at >= devices::kTcpFrameHeaderSize) {
                const std::uint8_t channel = in[at];
                const std::uint32_t len = devices::u3v::get_u32(in.data() + at + 1);
                if (channel != devices::kTcpChannelControl || len > 65536) {
                    return;  // protocol violation: drop the host
                }
                if (in.size() - at - devices::kTcpFrameHeaderSize < len) {
                    break;
                }
                const Bytes cmd(in.begin() + static_cast<std::ptrdiff_t>(at + 5),
                                in.begin() + static_cast<std::ptrdiff_t>(at + 5 + len));
                at += devices::kTcpFrameHeaderSize + len;
                for (const Bytes& ack : device_->handle_control(cmd)) {
                    if (!send_frame(fd, devices::kTcpChannelControl, ack)) {
                        return;
                    }
                }
                // Frames triggered by this command go out right after its acknowledge.
                for (const Bytes& pkt : device_->poll_stream()) {
                    if (!send_frame(fd, devices::kTcpChannelStream, pkt)) {
                        return;
                    }
                }
            }
            in.erase(in.begin(), in.begin() + static_cast<std::ptrdiff_t>(at));
        }
        if (continuous && Clock::now() >= next_continuous) {
            // Free-running acquisition: one frame per exposure time at most.
            const double exposure_us = device_->exposure_settings().exposure_us;
            next_continuous =
                Clock::now() + std::chrono::microseconds(static_cast<long long>(exposure_us));
            for (const Bytes& pkt : device_->poll_stream()) {
                if (!send_frame(fd, devices::kTcpChannelStream, pkt)) {
                    return;
                }
            }
        }
    }
}

}  // namespace gonio::sim
