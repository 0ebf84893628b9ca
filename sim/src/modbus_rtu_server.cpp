// The Modbus RTU server of the simulated controllers on a pseudo-terminal: frames delimited by
// their function's layout and CRC (the codec), replies framed with the unit address and CRC.

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <vector>

#include "gonio/devices/modbus_codec.h"
#include "modbus_server_loops.h"

namespace gonio::sim::detail {

namespace mb = devices::modbus;
using Bytes = std::vector<std::uint8_t>;

namespace {

/// Serves the whole frames at the front of `buf`: each request's reply goes out now or, when
/// delayed (or behind a delayed one), into `delayed`; garbled input and noise are dropped.
void serve_rtu_frames(const LoopContext& ctx,
                      Bytes& buf,
                      Bytes& out,
                      std::deque<std::pair<Clock::time_point, Bytes>>& delayed,
                      Clock::time_point& partial_since,
                      Clock::time_point now) {
    for (;;) {
        const std::size_t flen = mb::rtu_request_length(buf.data(), buf.size());
        if (flen == 0 || buf.size() < flen) {
            if (buf.size() > mb::kMaxRtuAdu) {
                buf.clear();  // Longer than any RTU frame: noise.
            }
            break;
        }
        auto frame = mb::parse_rtu_adu(buf.data(), flen);
        if (!frame) {
            buf.clear();  // Garbled (or too long): wait for the master to retry.
            break;
        }
        buf.erase(buf.begin(), buf.begin() + static_cast<long>(flen));
        partial_since = now;
        const Reply a = ctx.registers->process(frame->unit_id, frame->pdu, true);
        if (a.kind != Reply::Kind::kSend) {
            continue;
        }
        Bytes adu = mb::encode_rtu_adu(frame->unit_id, a.pdu);
        if (a.delay.count() > 0 || !delayed.empty()) {
            auto due = now + a.delay;
            if (!delayed.empty()) {
                due = std::max(due, delayed.back().first);
            }
            delayed.emplace_back(due, std::move(adu));
        } else {
            out.insert(out.end(), adu.begin(), adu.end());
        }
    }
}

}  // namespace

void serve_modbus_rtu(const LoopContext& ctx, int pty_master) {
    const ServerOptions& options = ctx.options;
    Bytes buf;
    Bytes out;
    std::deque<std::pair<Clock::time_point, Bytes>> delayed;
    bool down = false;
    Clock::time_point down_until = Clock::now();
    std::uint8_t chunk[512];
    Clock::time_point partial_since = Clock::now();
    // A partial frame that stays incomplete longer than the RTU inter-frame silence (3.5
    // characters at the line's baud rate) is noise: drop it. A pty has no line timing and delivers
    // bytes as the scheduler lets it, so the silence is never taken shorter than 50 ms.
    const auto partial_timeout = std::max<Clock::duration>(std::chrono::milliseconds(50),
                                                           mb::rtu_frame_silence(options.baud));
    while (*ctx.running) {
        auto now = Clock::now();
        if (auto b = ctx.take_blip()) {
            down = true;
            down_until = b->until;
            buf.clear();
            ctx.log("line silent for " + std::to_string(b->length.count()) +
                    " ms (simulated blip)");
        }
        if (down && now >= down_until) {
            down = false;
        }
        auto next = now + std::chrono::milliseconds(1000);
        if (!buf.empty()) {
            next = std::min(next, partial_since + partial_timeout);
        }
        if (!delayed.empty()) {
            next = std::min(next, delayed.front().first);
        }
        if (down) {
            next = std::min(next, down_until);
        }
        pollfd fds[2] = {{ctx.wake_fd, POLLIN, 0},
                         {pty_master, static_cast<short>(POLLIN | (out.empty() ? 0 : POLLOUT)), 0}};
        const auto wait_ms = std::chrono::duration_cast<std::chrono::milliseconds>(next - now);
        const int rc =
            ::poll(fds, 2, static_cast<int>(std::max<long long>(0, wait_ms.count() + 1)));
        if (rc < 0 && errno != EINTR) {
            break;
        }
        now = Clock::now();
        if ((fds[0].revents & POLLIN) != 0) {
            ctx.drain_wake();
            continue;
        }
        if (!buf.empty() && now - partial_since > partial_timeout) {
            buf.clear();
        }
        if ((fds[1].revents & POLLIN) != 0) {
            const ssize_t n = ::read(pty_master, chunk, sizeof chunk);
            if (n > 0 && !down) {
                if (buf.empty()) {
                    partial_since = now;
                }
                buf.insert(buf.end(), chunk, chunk + n);
            }
        }
        serve_rtu_frames(ctx, buf, out, delayed, partial_since, now);
        while (!delayed.empty() && delayed.front().first <= now) {
            out.insert(out.end(), delayed.front().second.begin(), delayed.front().second.end());
            delayed.pop_front();
        }
        if (!out.empty()) {
            const ssize_t n = ::write(pty_master, out.data(), out.size());
            if (n > 0) {
                out.erase(out.begin(), out.begin() + n);
            }
            if (out.size() > options.max_output_bytes) {
                out.clear();  // Nobody reads the line.
            }
        }
    }
}

}  // namespace gonio::sim::detail
