// The host side of U3V-over-TCP: one socket carrying framed control and stream transfers,
// demultiplexed into two queues.

#include "gonio/devices/u3v_tcp.h"

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
#include <deque>

#include "gonio/devices/u3v_bootstrap.h"

namespace gonio::devices {

Bytes encode_tcp_frame_header(std::uint8_t channel, std::uint32_t length) {
    Bytes h;
    h.push_back(channel);
    u3v::put_u32(h, length);
    return h;
}

namespace {

using Clock = std::chrono::steady_clock;

class TcpTransport : public U3vTransport {
  public:
    TcpTransport(int fd, std::string name) : fd_(fd), name_(std::move(name)) {}
    ~TcpTransport() override { ::close(fd_); }

    Expected<void> control_out(const Bytes& bytes, std::chrono::milliseconds timeout) override {
        if (closed_) {
            return fail(TransportFailure::kDisconnected, "connection closed by the device");
        }
        Bytes frame =
            encode_tcp_frame_header(kTcpChannelControl, static_cast<std::uint32_t>(bytes.size()));
        frame.insert(frame.end(), bytes.begin(), bytes.end());
        const auto deadline = Clock::now() + timeout;
        std::size_t sent = 0;
        while (sent < frame.size()) {
            const ssize_t n =
                ::send(fd_, frame.data() + sent, frame.size() - sent, MSG_NOSIGNAL | MSG_DONTWAIT);
            if (n > 0) {
                sent += static_cast<std::size_t>(n);
                continue;
            }
            if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) {
                // The device is not reading: keep its replies flowing while we wait.
                auto r = pump(deadline, /*for_write=*/true);
                if (!r) {
                    return tl::unexpected(r.error());
                }
                continue;
            }
            closed_ = true;
            return fail(TransportFailure::kDisconnected,
                        std::string("send failed: ") + std::strerror(errno));
        }
        return {};
    }

    Expected<Bytes> control_in(std::size_t max_bytes, std::chrono::milliseconds timeout) override {
        return take(control_, max_bytes, timeout, "acknowledge");
    }

    Expected<Bytes> stream_in(std::size_t max_bytes, std::chrono::milliseconds timeout) override {
        return take(stream_, max_bytes, timeout, "stream");
    }

    void stream_flush() override {
        (void)pump(Clock::now(), false);
        stream_.clear();
    }

    TransportFailure last_failure() const override { return failure_; }
    std::string describe() const override { return name_; }

  private:
    tl::unexpected<Error> fail(TransportFailure f, const std::string& msg) {
        failure_ = f;
        return make_error(name_ + ": " + msg);
    }

    Expected<Bytes> take(std::deque<Bytes>& q,
                         std::size_t max_bytes,
                         std::chrono::milliseconds timeout,
                         const char* what) {
        const auto deadline = Clock::now() + timeout;
        while (q.empty()) {
            if (closed_) {
                return fail(TransportFailure::kDisconnected, "connection closed by the device");
            }
            if (Clock::now() >= deadline) {
                return fail(TransportFailure::kTimeout,
                            std::string("no ") + what + " transfer within " +
                                std::to_string(timeout.count()) + " ms");
            }
            auto r = pump(deadline, false);
            if (!r) {
                return tl::unexpected(r.error());
            }
        }
        Bytes b = std::move(q.front());
        q.pop_front();
        if (b.size() > max_bytes) {
            return fail(TransportFailure::kOther,
                        std::string(what) + " transfer of " + std::to_string(b.size()) +
                            " bytes overflows the " + std::to_string(max_bytes) + "-byte buffer");
        }
        return b;
    }

    // Waits until readable (or writable when for_write) or the deadline, reads what is there and
    // splits it into frames.
    Expected<void> pump(Clock::time_point deadline, bool for_write) {
        const auto left =
            std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
        pollfd p{fd_, static_cast<short>(POLLIN | (for_write ? POLLOUT : 0)), 0};
        const int rc = ::poll(&p, 1, left.count() > 0 ? static_cast<int>(left.count()) : 0);
        if (rc < 0 && errno != EINTR) {
            return fail(TransportFailure::kOther, std::string("poll: ") + std::strerror(errno));
        }
        if (rc <= 0) {
            if (for_write && Clock::now() >= deadline) {
                return fail(TransportFailure::kTimeout, "send blocked until the deadline");
            }
            return {};
        }
        if (p.revents & (POLLIN | POLLHUP | POLLERR)) {
            std::uint8_t buf[1 << 16];
            for (;;) {
                const ssize_t n = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
                if (n > 0) {
                    in_.insert(in_.end(), buf, buf + n);
                    if (static_cast<std::size_t>(n) < sizeof buf) {
                        break;
                    }
                    continue;
                }
                if (n == 0) {
                    closed_ = true;
                    break;
                }
                if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) {
                    break;
                }
                closed_ = true;
                break;
            }
            return split();
        }
        return {};
    }

    Expected<void> split() {
        std::size_t at = 0;
        while (in_.size() - at >= kTcpFrameHeaderSize) {
            const std::uint8_t channel = in_[at];
            const std::uint32_t length = u3v::get_u32(in_.data() + at + 1);
            if (channel > kTcpChannelStream || length > kTcpMaxFrameLength) {
                closed_ = true;
                return fail(TransportFailure::kOther,
                            "malformed frame (channel " + std::to_string(channel) + ", length " +
                                std::to_string(length) + ")");
            }
            if (in_.size() - at - kTcpFrameHeaderSize < length) {
                break;
            }
            const auto* b = in_.data() + at + kTcpFrameHeaderSize;
            (channel == kTcpChannelControl ? control_ : stream_).emplace_back(b, b + length);
            at += kTcpFrameHeaderSize + length;
        }
        in_.erase(in_.begin(), in_.begin() + static_cast<std::ptrdiff_t>(at));
        return {};
    }

    int fd_;
    std::string name_;
    bool closed_ = false;
    TransportFailure failure_ = TransportFailure::kOther;
    Bytes in_;
    std::deque<Bytes> control_;
    std::deque<Bytes> stream_;
};

}  // namespace

Expected<std::unique_ptr<U3vTransport>> connect_u3v_tcp(const std::string& host,
                                                        std::uint16_t port) {
    const std::string name = "u3v-tcp://" + host + ":" + std::to_string(port);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(port);
    if (::inet_pton(AF_INET, host.c_str(), &addr.sin_addr) != 1) {
        return make_error(name + ": host '" + host + "' is not a numeric IPv4 address");
    }
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        return make_error(name + ": socket: " + std::strerror(errno));
    }
    if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
        const int err = errno;
        ::close(fd);
        return make_error(name + ": connect: " + std::strerror(err) +
                          " (is the simulated camera served?)");
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    return std::unique_ptr<U3vTransport>(new TcpTransport(fd, name));
}

}  // namespace gonio::devices
