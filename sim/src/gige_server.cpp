// UDP transport of the simulated GigE Vision camera.

#include "gonio/sim/gige_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <random>
#include <vector>

#include "gonio/devices/gvsp.h"

namespace gonio::sim {

namespace gvcp = devices::gvcp;
namespace gvsp = devices::gvsp;

namespace {

constexpr std::size_t kRetainedFrames = 4;
constexpr std::size_t kBatch = 64;
constexpr int kPollMs = 20;

}  // namespace

struct GigeServer::SentFrame {
    RenderedFrame frame;
    StreamTarget target;
    std::vector<std::uint8_t> leader;
    std::vector<std::uint8_t> trailer;
    std::size_t per_packet = 0;
    std::uint32_t payload_packets = 0;  ///< packet ids 1..payload_packets
};

GigeServer::GigeServer(std::shared_ptr<GigeCamera> camera) : camera_(std::move(camera)) {}

GigeServer::~GigeServer() {
    stop();
}

std::string GigeServer::address() const {
    return "gige://" + ip_;
}

GigeServerStats GigeServer::stats() const {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    return stats_;
}

Expected<void> GigeServer::start(const std::string& ip, std::uint16_t port) {
    return start_impl(ip, port, nullptr);
}

Expected<void> GigeServer::start_on_free_loopback(int attempts) {
    // Linux delivers every 127.0.0.0/8 address to the loopback interface, so each simulated camera
    // can own GVCP's fixed port on an address of its own. The search starts at a random point of
    // 127.16.0.1 .. 127.255.255.254 (127.0.x.x stays free for other uses).
    std::random_device rd;
    std::mt19937 gen(rd() ^ static_cast<std::uint32_t>(getpid()));
    std::uniform_int_distribution<std::uint32_t> pick(0, (240u << 16) - 1);
    std::string tried;
    for (int i = 0; i < attempts; ++i) {
        const std::uint32_t k = pick(gen);
        const std::uint32_t b = 16 + (k >> 16), c = (k >> 8) & 0xFF, d = 1 + (k & 0xFF) % 254;
        const std::string ip =
            "127." + std::to_string(b) + "." + std::to_string(c) + "." + std::to_string(d);
        int bind_errno = 0;
        auto r = start_impl(ip, gvcp::kPort, &bind_errno);
        if (bind_errno == EADDRNOTAVAIL) {
            // A network stack that gives loopback 127.0.0.1 alone: the one address there is.
            return start_impl("127.0.0.1", gvcp::kPort, nullptr);
        }
        if (r || bind_errno != EADDRINUSE) {
            return r;
        }
        tried = ip;
    }
    return make_error("GigE camera server: no free loopback address after " +
                      std::to_string(attempts) + " tries (last " + tried + ")");
}

Expected<void> GigeServer::start_impl(const std::string& ip, std::uint16_t port, int* bind_errno) {
    ip_ = ip;
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    if (inet_pton(AF_INET, ip.c_str(), &a.sin_addr) != 1) {
        return make_error("GigE camera server: '" + ip + "' is not an IPv4 address");
    }
    gvcp_fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    gvsp_fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    wake_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (gvcp_fd_ < 0 || gvsp_fd_ < 0 || wake_fd_ < 0) {
        const std::string e = std::strerror(errno);
        stop();
        return make_error("GigE camera server: socket: " + e);
    }
    if (bind(gvcp_fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
        if (bind_errno != nullptr) {
            *bind_errno = errno;
        }
        const int code = errno;
        const std::string e = std::strerror(code);
        stop();
        const char* hint =
            code == EADDRINUSE      ? " (is another GigE Vision camera served on this address?)"
            : code == EADDRNOTAVAIL ? " (not an address of this machine; 127.0.0.1 is)"
                                    : "";
        return make_error("GigE camera server: bind " + ip + ":" + std::to_string(port) + ": " + e +
                          hint);
    }
    sockaddr_in s = a;
    s.sin_port = 0;
    if (bind(gvsp_fd_, reinterpret_cast<const sockaddr*>(&s), sizeof s) != 0) {
        const std::string e = std::strerror(errno);
        stop();
        return make_error("GigE camera server: stream socket bind " + ip + ": " + e);
    }
    socklen_t len = sizeof s;
    getsockname(gvsp_fd_, reinterpret_cast<sockaddr*>(&s), &len);
    camera_->set_stream_source_port(ntohs(s.sin_port));
    const int sndbuf = 4 << 20;
    setsockopt(gvsp_fd_, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof sndbuf);
    stop_ = false;
    control_thread_ = std::thread([this] { control_loop(); });
    stream_thread_ = std::thread([this] { stream_loop(); });
    return {};
}

void GigeServer::stop() {
    stop_ = true;
    if (wake_fd_ >= 0) {
        const std::uint64_t one = 1;
        [[maybe_unused]] const ssize_t n = write(wake_fd_, &one, sizeof one);
    }
    {
        std::lock_guard<std::mutex> lock(wake_mutex_);
        kicked_ = true;
    }
    wake_.notify_all();
    if (control_thread_.joinable()) {
        control_thread_.join();
    }
    if (stream_thread_.joinable()) {
        stream_thread_.join();
    }
    for (int* fd : {&gvcp_fd_, &gvsp_fd_, &wake_fd_}) {
        if (*fd >= 0) {
            close(*fd);
            *fd = -1;
        }
    }
}

void GigeServer::wake() {
    {
        std::lock_guard<std::mutex> lock(wake_mutex_);
        kicked_ = true;
    }
    wake_.notify_all();
}

void GigeServer::control_loop() {
    std::vector<std::uint8_t> buf(2048);
    pollfd fds[2] = {{gvcp_fd_, POLLIN, 0}, {wake_fd_, POLLIN, 0}};
    while (!stop_) {
        const int n = poll(fds, 2, kPollMs);
        const auto now = GigeCamera::Clock::now();
        if (n > 0 && (fds[0].revents & POLLIN) != 0) {
            sockaddr_in from{};
            socklen_t flen = sizeof from;
            const ssize_t got = recvfrom(gvcp_fd_,
                                         buf.data(),
                                         buf.size(),
                                         MSG_DONTWAIT,
                                         reinterpret_cast<sockaddr*>(&from),
                                         &flen);
            if (got > 0) {
                const HostId host{ntohl(from.sin_addr.s_addr), ntohs(from.sin_port)};
                std::optional<gvcp::PacketResend> rs;
                auto ack =
                    camera_->handle_gvcp(buf.data(), static_cast<std::size_t>(got), host, now, &rs);
                if (ack) {
                    sendto(gvcp_fd_,
                           ack->data(),
                           ack->size(),
                           0,
                           reinterpret_cast<const sockaddr*>(&from),
                           flen);
                }
                if (rs) {
                    resend(*rs);
                }
                // A command may have started acquisition or fired a trigger.
                {
                    std::lock_guard<std::mutex> lock(wake_mutex_);
                    kicked_ = true;
                }
                wake_.notify_all();
            }
        }
        if (camera_->check_heartbeat(now)) {
            std::lock_guard<std::mutex> lock(wake_mutex_);
            kicked_ = true;
        }
    }
}

void GigeServer::stream_loop() {
    while (!stop_) {
        GigeCamera::Clock::time_point due;
        auto frame = camera_->next_frame(GigeCamera::Clock::now(), &due);
        if (frame && camera_->take_frame_drop()) {
            std::lock_guard<std::mutex> lock(stats_mutex_);
            ++stats_.frames_dropped;
            continue;
        }
        if (frame) {
            auto target = camera_->stream_target();
            if (!target) {
                continue;  // the channel closed while rendering
            }
            auto sf = std::make_shared<SentFrame>();
            sf->frame = std::move(*frame);
            sf->target = *target;
            sf->per_packet = gvsp::payload_bytes_per_packet(target->packet_size);
            const std::size_t size = sf->frame.payload.size();
            sf->payload_packets = static_cast<std::uint32_t>(
                sf->per_packet == 0 ? 0 : (size + sf->per_packet - 1) / sf->per_packet);
            gvsp::ImageLeader l;
            l.timestamp = sf->frame.timestamp_ns;
            l.pixel_format = sf->frame.pixel_format;
            l.size_x = static_cast<std::uint32_t>(sf->frame.width);
            l.size_y = static_cast<std::uint32_t>(sf->frame.height);
            l.offset_x = static_cast<std::uint32_t>(sf->frame.offset_x);
            l.offset_y = static_cast<std::uint32_t>(sf->frame.offset_y);
            sf->leader = gvsp::encode_leader(sf->frame.block_id, l);
            sf->trailer = gvsp::encode_trailer(
                sf->frame.block_id, sf->payload_packets + 1, gvsp::ImageTrailer{l.size_y});
            {
                std::lock_guard<std::mutex> lock(frames_mutex_);
                recent_.push_back(sf);
                while (recent_.size() > kRetainedFrames) {
                    recent_.pop_front();
                }
            }
            send_frame(sf);
            continue;
        }
        std::unique_lock<std::mutex> lock(wake_mutex_);
        const auto limit = GigeCamera::Clock::now() + std::chrono::milliseconds(kPollMs);
        wake_.wait_until(lock, std::min(due, limit), [this] { return kicked_ || stop_.load(); });
        kicked_ = false;
    }
}

void GigeServer::send_frame(const std::shared_ptr<SentFrame>& f) {
    send_packets(*f, 0, f->payload_packets + 1, true);
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.frames_sent;
}

void GigeServer::send_packets(const SentFrame& f,
                              std::uint32_t first,
                              std::uint32_t last,
                              bool first_time) {
    const GigeFaults faults = camera_->faults();
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(f.target.port);
    to.sin_addr.s_addr = htonl(f.target.ip);
    std::vector<std::array<std::uint8_t, gvsp::kHeaderSize>> headers(kBatch);
    std::vector<iovec> iov(2 * kBatch);
    std::vector<mmsghdr> msgs(kBatch);
    std::uint64_t sent = 0, dropped = 0;
    const std::uint32_t trailer_id = f.payload_packets + 1;
    std::uint32_t id = first;
    while (id <= last && !stop_) {
        std::size_t k = 0;
        for (; k < kBatch && id <= last; ++id) {
            const bool payload = id >= 1 && id <= f.payload_packets;
            if (payload && faults.drop_every_nth_packet > 0 &&
                id % static_cast<std::uint32_t>(faults.drop_every_nth_packet) == 0 &&
                (first_time || faults.refuse_resend)) {
                ++dropped;
                continue;
            }
            mmsghdr& mh = msgs[k];
            std::memset(&mh, 0, sizeof mh);
            mh.msg_hdr.msg_name = &to;
            mh.msg_hdr.msg_namelen = sizeof to;
            if (id == 0) {
                iov[2 * k] = {const_cast<std::uint8_t*>(f.leader.data()), f.leader.size()};
                mh.msg_hdr.msg_iovlen = 1;
            } else if (id == trailer_id) {
                iov[2 * k] = {const_cast<std::uint8_t*>(f.trailer.data()), f.trailer.size()};
                mh.msg_hdr.msg_iovlen = 1;
            } else {
                gvsp::encode_header(gvsp::Header{0, f.frame.block_id, gvsp::Format::kPayload, id},
                                    headers[k].data());
                const std::size_t at = static_cast<std::size_t>(id - 1) * f.per_packet;
                const std::size_t n = std::min(f.per_packet, f.frame.payload.size() - at);
                iov[2 * k] = {headers[k].data(), headers[k].size()};
                iov[2 * k + 1] = {const_cast<std::uint8_t*>(f.frame.payload.data() + at), n};
                mh.msg_hdr.msg_iovlen = 2;
            }
            mh.msg_hdr.msg_iov = &iov[2 * k];
            ++k;
        }
        std::size_t done = 0;
        int refused = 0;
        while (done < k) {
            const int r =
                sendmmsg(gvsp_fd_, msgs.data() + done, static_cast<unsigned>(k - done), 0);
            if (r < 0) {
                if (errno == EINTR || errno == EAGAIN || errno == ENOBUFS) {
                    continue;
                }
                // ECONNREFUSED reports an ICMP "port unreachable" of an earlier datagram (a
                // stream port the host has since closed) and clears it: the call sent nothing
                // and the next one goes through. Repeated refusals: the host went away; the rest
                // of this batch is dropped.
                if (errno == ECONNREFUSED && ++refused <= 2) {
                    continue;
                }
                break;
            }
            refused = 0;
            done += static_cast<std::size_t>(r);
        }
        sent += done;
        if (f.target.packet_delay_ticks > 0) {
            std::this_thread::sleep_for(std::chrono::nanoseconds(
                static_cast<std::uint64_t>(f.target.packet_delay_ticks) * k));
        }
    }
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (first_time) {
        stats_.packets_sent += sent;
        stats_.packets_dropped += dropped;
    } else {
        stats_.packets_resent += sent;
    }
}

void GigeServer::resend(const gvcp::PacketResend& r) {
    std::shared_ptr<SentFrame> f;
    {
        std::lock_guard<std::mutex> lock(frames_mutex_);
        for (const auto& c : recent_) {
            if (c->frame.block_id == static_cast<std::uint16_t>(r.block_id)) {
                f = c;
            }
        }
    }
    {
        std::lock_guard<std::mutex> lock(stats_mutex_);
        ++stats_.resend_requests;
        if (!f) {
            // In 64 bits: packets 0..0xFFFFFFFF are 2^32 of them, not 0.
            stats_.resend_unavailable +=
                r.last_packet_id >= r.first_packet_id
                    ? std::uint64_t{r.last_packet_id} - r.first_packet_id + 1
                    : 0;
        }
    }
    if (!f || r.first_packet_id > r.last_packet_id) {
        return;
    }
    // The trailer is packet payload_packets + 1 (64-bit sum: no wrap for a frame of 2^32 - 1).
    const auto last = static_cast<std::uint32_t>(
        std::min<std::uint64_t>(r.last_packet_id, std::uint64_t{f->payload_packets} + 1));
    if (r.first_packet_id <= last) {
        send_packets(*f, r.first_packet_id, last, false);
    }
}

}  // namespace gonio::sim
