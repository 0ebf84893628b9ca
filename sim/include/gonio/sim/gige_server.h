#pragma once

// Serves a simulated GigE Vision camera on UDP: GVCP on 127.0.0.1:3956 (the fixed port every
// GigE Vision host talks to), GVSP from an ephemeral port to the destination the host programs
// (SCDA, SCP, SCPS). One thread answers the control channel and enforces the heartbeat; one
// thread renders and streams frames, keeping the last frames for PACKETRESEND.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "gonio/base/error.h"
#include "gonio/sim/gige_camera.h"

namespace gonio::sim {

struct GigeServerStats {
    std::uint64_t frames_sent = 0;
    std::uint64_t frames_dropped = 0;   ///< withheld whole by the drop_frames fault
    std::uint64_t packets_sent = 0;     ///< first transmissions (leader, payload, trailer)
    std::uint64_t packets_dropped = 0;  ///< withheld by the drop fault
    std::uint64_t resend_requests = 0;  ///< PACKETRESEND commands received
    std::uint64_t packets_resent = 0;
    std::uint64_t resend_unavailable = 0;  ///< packets asked for that were no longer held
};

class GigeServer {
  public:
    explicit GigeServer(std::shared_ptr<GigeCamera> camera);
    ~GigeServer();
    GigeServer(const GigeServer&) = delete;
    GigeServer& operator=(const GigeServer&) = delete;

    /// Binds GVCP to ip:port (default 127.0.0.1:3956) and starts both threads. Fails when the
    /// port is taken (another GigE Vision device is served on this machine).
    Expected<void> start(const std::string& ip = "127.0.0.1",
                         std::uint16_t port = devices::gvcp::kPort);
    /// Binds GVCP to port 3956 of a free address of its own in 127.16.0.0 - 127.255.255.255 (all
    /// loopback on Linux), trying at most `attempts` addresses: several simulated cameras, and
    /// tests running in parallel, then never compete for 127.0.0.1:3956.
    Expected<void> start_on_free_loopback(int attempts = 64);
    /// Stops both threads and closes the sockets (idempotent).
    void stop();
    /// "gige://127.0.0.1" (the address served on)
    std::string address() const;
    GigeServerStats stats() const;
    GigeCamera& camera() { return *camera_; }
    /// Wakes the stream thread (a frame was queued other than through GVCP: a line trigger).
    void wake();

  private:
    struct SentFrame;
    Expected<void> start_impl(const std::string& ip, std::uint16_t port, int* bind_errno);
    void control_loop();
    void stream_loop();
    void send_frame(const std::shared_ptr<SentFrame>& f);
    void resend(const devices::gvcp::PacketResend& r);
    /// Sends packets [first, last] of a frame; `first_time` applies the drop fault.
    void send_packets(const SentFrame& f, std::uint32_t first, std::uint32_t last, bool first_time);

    std::shared_ptr<GigeCamera> camera_;
    std::string ip_;
    int gvcp_fd_ = -1;
    int gvsp_fd_ = -1;
    int wake_fd_ = -1;
    std::atomic<bool> stop_{false};
    std::thread control_thread_;
    std::thread stream_thread_;
    std::mutex wake_mutex_;
    std::condition_variable wake_;
    bool kicked_ = false;
    mutable std::mutex frames_mutex_;
    std::deque<std::shared_ptr<SentFrame>> recent_;
    mutable std::mutex stats_mutex_;
    GigeServerStats stats_;
};

}  // namespace gonio::sim
