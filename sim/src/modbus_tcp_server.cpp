// The Modbus TCP server of the simulated controllers: one thread, poll() over the listener and
// every connection, non-blocking I/O with per-connection buffers, MBAP framing by the codec.

#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <vector>

#include "gonio/devices/modbus_codec.h"
#include "modbus_server_loops.h"

namespace gonio::sim::detail {
namespace {

namespace mb = devices::modbus;
using Bytes = std::vector<std::uint8_t>;

/// Complete frames served per connection per turn of the event loop (fairness under a flood).
constexpr int kFramesPerTurn = 8;
/// Unserved input held per connection; beyond it the connection is not read until served.
constexpr std::size_t kMaxInputBytes = 4096;
/// Kernel send buffer of a client socket: small, so that a client that does not read shows up in
/// our own bounded output buffer soon.
constexpr int kSocketSendBuffer = 16 * 1024;

/// One TCP client: its own input and output buffers, never a blocking call.
struct Conn {
    int fd = -1;
    std::uint64_t id = 0;
    Bytes in;
    Clock::time_point partial_since;  ///< When the incomplete frame in `in` began.
    Bytes out;
    std::deque<std::pair<Clock::time_point, Bytes>> delayed;  ///< Replies held back.
    bool backlog = false;  ///< Complete frames left in `in` for the next turn.
};

/// Queues a reply behind any delayed one (replies leave in request order).
void queue_reply(Conn& c, Bytes adu, std::chrono::milliseconds delay, Clock::time_point now) {
    if (delay.count() > 0 || !c.delayed.empty()) {
        Clock::time_point due = now + delay;
        if (!c.delayed.empty()) {
            due = std::max(due, c.delayed.back().first);
        }
        c.delayed.emplace_back(due, std::move(adu));
        return;
    }
    c.out.insert(c.out.end(), adu.begin(), adu.end());
}

/// Parses and answers at most `budget` complete MBAP frames of a connection. False: the stream
/// cannot be trusted any more (the connection is closed).
bool serve_frames(const LoopContext& ctx, Conn& c, int budget, Clock::time_point now) {
    std::size_t off = 0;
    int done = 0;
    for (;;) {
        const mb::TcpFrame f = mb::next_tcp_frame(c.in.data() + off, c.in.size() - off);
        if (f.status == mb::TcpFrame::Status::kIncomplete) {
            break;
        }
        if (f.status == mb::TcpFrame::Status::kBroken) {
            ctx.log("client " + std::to_string(c.id) + ": " + f.error +
                    "; connection closed (the frame boundaries are lost)");
            return false;
        }
        if (done == budget) {
            c.backlog = true;
            break;
        }
        // A protocol id other than 0 is not Modbus: the frame is discarded unanswered.
        if (f.header.protocol_id == 0) {
            const Reply a = ctx.registers->process(f.header.unit_id, f.pdu, false);
            if (a.kind == Reply::Kind::kDrop) {
                return false;
            }
            if (a.kind == Reply::Kind::kSend) {
                queue_reply(c,
                            mb::encode_tcp_adu(f.header.transaction_id, f.header.unit_id, a.pdu),
                            a.delay,
                            now);
            }
        }
        off += f.consumed;
        ++done;
    }
    if (done < budget) {
        c.backlog = false;
    }
    if (off > 0) {
        c.in.erase(c.in.begin(), c.in.begin() + static_cast<long>(off));
        c.partial_since = now;
    }
    return true;
}

/// Writes what the socket takes now. False: the peer is gone.
bool flush(int fd, Bytes& out) {
    while (!out.empty()) {
        const ssize_t n = ::send(fd, out.data(), out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            return errno == EAGAIN || errno == EWOULDBLOCK;
        }
        out.erase(out.begin(), out.begin() + n);
    }
    return true;
}

/// Accepts the pending connections, up to 64 a turn; past the connection limit, or out of
/// descriptors (the spare one released for it), a connection is accepted and closed.
void accept_pending(const LoopContext& ctx,
                    int listen_fd,
                    std::vector<std::unique_ptr<Conn>>& conns,
                    std::uint64_t& next_id,
                    std::uint64_t& refused,
                    int& spare) {
    const ServerOptions& options = ctx.options;
    for (int k = 0; k < 64; ++k) {
        const int c = ::accept4(listen_fd, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (c < 0) {
            if ((errno == EMFILE || errno == ENFILE) && spare >= 0) {
                ::close(spare);
                const int x = ::accept(listen_fd, nullptr, nullptr);
                if (x >= 0) {
                    ::close(x);
                }
                spare = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
                ctx.log("out of file descriptors: refused a connection");
                continue;
            }
            break;
        }
        if (static_cast<int>(conns.size()) >= options.max_connections) {
            ::close(c);
            if (refused++ % 100 == 0) {
                ctx.log("connection limit " + std::to_string(options.max_connections) +
                        " reached: refused a connection (" + std::to_string(refused) +
                        " refused so far)");
            }
            continue;
        }
        const int one = 1;
        ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        ::setsockopt(c, SOL_SOCKET, SO_SNDBUF, &kSocketSendBuffer, sizeof kSocketSendBuffer);
        auto conn = std::make_unique<Conn>();
        conn->fd = c;
        conn->id = next_id++;
        conns.push_back(std::move(conn));
    }
}

/// One turn of one connection: reads what arrived, serves whole frames, sends the replies due;
/// false when the connection is to be closed (peer gone, replies not read, frame incomplete too
/// long).
bool serve_connection(const LoopContext& ctx, Conn& c, short re, Clock::time_point now) {
    const ServerOptions& options = ctx.options;
    const auto frame_timeout = std::chrono::milliseconds(options.frame_timeout_ms);
    bool ok = true;
    if ((re & (POLLIN | POLLHUP | POLLERR)) != 0 && c.in.size() < kMaxInputBytes) {
        std::uint8_t buf[4096];
        const ssize_t n = ::recv(c.fd, buf, sizeof buf, MSG_DONTWAIT);
        if (n > 0) {
            if (c.in.empty()) {
                c.partial_since = now;
            }
            c.in.insert(c.in.end(), buf, buf + n);
        } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
            ok = false;
        }
    }
    if (ok && (!c.in.empty())) {
        ok = serve_frames(ctx, c, kFramesPerTurn, now);
    }
    while (ok && !c.delayed.empty() && c.delayed.front().first <= now) {
        c.out.insert(c.out.end(), c.delayed.front().second.begin(), c.delayed.front().second.end());
        c.delayed.pop_front();
    }
    if (ok && !c.out.empty()) {
        ok = flush(c.fd, c.out);
    }
    if (ok && c.out.size() > options.max_output_bytes) {
        ctx.log("client " + std::to_string(c.id) + " does not read its replies (" +
                std::to_string(c.out.size()) + " bytes pending, limit " +
                std::to_string(options.max_output_bytes) + "): connection closed");
        ok = false;
    }
    if (ok && !c.in.empty() && !c.backlog && frame_timeout.count() > 0 &&
        now - c.partial_since > frame_timeout) {
        ctx.log("client " + std::to_string(c.id) + ": incomplete frame (" +
                std::to_string(c.in.size()) + " bytes) for more than " +
                std::to_string(options.frame_timeout_ms) + " ms: connection closed");
        ok = false;
    }
    return ok;
}

}  // namespace

int make_tcp_listener(int port, std::string* err) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) {
        *err = std::strerror(errno);
        return -1;
    }
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    sa.sin_port = htons(static_cast<std::uint16_t>(port));
    if (::bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0 || ::listen(fd, 128) != 0) {
        *err = std::strerror(errno);
        ::close(fd);
        return -1;
    }
    return fd;
}

void serve_modbus_tcp(const LoopContext& ctx, int& listen_fd, int port) {
    std::vector<std::unique_ptr<Conn>> conns;
    std::uint64_t next_id = 1;
    std::uint64_t refused = 0;
    // A descriptor kept in reserve: when the process runs out of descriptors, it is released
    // to accept and close the pending connection, so the listener does not spin.
    int spare = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    bool down = false;
    Clock::time_point down_until = Clock::now();
    std::vector<pollfd> fds;
    const ServerOptions& options = ctx.options;
    const auto frame_timeout = std::chrono::milliseconds(options.frame_timeout_ms);
    auto close_conn = [&](size_t i) {
        ::close(conns[i]->fd);
        conns.erase(conns.begin() + static_cast<long>(i));
    };
    while (*ctx.running) {
        auto now = Clock::now();
        if (auto b = ctx.take_blip()) {
            // The gateway loses power: every connection and the listener go away.
            for (auto& c : conns) {
                ::close(c->fd);
            }
            conns.clear();
            if (listen_fd >= 0) {
                ::close(listen_fd);
                listen_fd = -1;
            }
            down = true;
            down_until = b->until;
            ctx.log("link down for " + std::to_string(b->length.count()) + " ms (simulated blip)");
        }
        if (down && now >= down_until) {
            std::string err;
            listen_fd = make_tcp_listener(port, &err);
            if (listen_fd >= 0) {
                down = false;
                ctx.log("link up again on 127.0.0.1:" + std::to_string(port));
            } else {
                down_until = now + std::chrono::milliseconds(50);
            }
        }
        // Poll timeout: the next delayed reply, partial-frame deadline or blip end.
        auto next = now + std::chrono::milliseconds(1000);
        bool busy = false;
        for (const auto& c : conns) {
            if (!c->delayed.empty()) {
                next = std::min(next, c->delayed.front().first);
            }
            if (!c->in.empty() && frame_timeout.count() > 0) {
                next = std::min(next, c->partial_since + frame_timeout);
            }
            busy = busy || c->backlog;
        }
        if (down) {
            next = std::min(next, down_until);
        }
        fds.clear();
        fds.push_back({ctx.wake_fd, POLLIN, 0});
        fds.push_back({listen_fd, POLLIN, 0});  // A negative fd is ignored by poll().
        for (const auto& c : conns) {
            // A connection with unserved input is not read further (its sender waits, nobody
            // else does).
            const short want_in = c->in.size() < kMaxInputBytes ? POLLIN : 0;
            fds.push_back({c->fd, static_cast<short>(want_in | (c->out.empty() ? 0 : POLLOUT)), 0});
        }
        const auto wait_ms = std::chrono::duration_cast<std::chrono::milliseconds>(next - now);
        const int timeout =
            busy ? 0 : static_cast<int>(std::max<long long>(0, wait_ms.count() + 1));
        const int rc = ::poll(fds.data(), fds.size(), timeout);
        if (rc < 0 && errno != EINTR) {
            break;
        }
        now = Clock::now();
        if ((fds[0].revents & POLLIN) != 0) {
            ctx.drain_wake();
            continue;  // Stop or blip: re-check at the top.
        }
        if (listen_fd >= 0 && (fds[1].revents & POLLIN) != 0) {
            accept_pending(ctx, listen_fd, conns, next_id, refused, spare);
        }
        // Existing connections (the ones accepted just now are served next turn).
        for (size_t i = 0, pi = 2; i < conns.size(); ++pi) {
            Conn& c = *conns[i];
            const short re = pi < fds.size() && fds[pi].fd == c.fd ? fds[pi].revents : 0;
            const bool ok = serve_connection(ctx, c, re, now);
            if (!ok) {
                close_conn(i);
                continue;
            }
            ++i;
        }
    }
    for (auto& c : conns) {
        ::close(c->fd);
    }
    if (spare >= 0) {
        ::close(spare);
    }
}

}  // namespace gonio::sim::detail
