#pragma once

// Serves a simulated U3V device over TCP on 127.0.0.1 (port 0 = any free port) with the framing of
// devices/u3v_tcp.h, so that another process opens it as "u3v-tcp://127.0.0.1:PORT". One client
// at a time; a new client replaces nothing until the previous one disconnects.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include "gonio/sim/u3v_device.h"

namespace gonio::sim {

class U3vTcpServer {
  public:
    explicit U3vTcpServer(std::shared_ptr<U3vDevice> device);
    ~U3vTcpServer();
    U3vTcpServer(const U3vTcpServer&) = delete;
    U3vTcpServer& operator=(const U3vTcpServer&) = delete;

    /// Binds 127.0.0.1:port (0 = any) and starts the serving thread.
    Expected<void> start(std::uint16_t port = 0);
    void stop();
    std::uint16_t port() const { return port_; }
    /// "u3v-tcp://127.0.0.1:PORT"
    std::string address() const;

  private:
    void run();
    void serve_client(int fd);

    std::shared_ptr<U3vDevice> device_;
    int listen_fd_ = -1;
    int wake_pipe_[2] = {-1, -1};
    std::uint16_t port_ = 0;
    std::atomic<bool> stop_{false};
    std::thread thread_;
};

}  // namespace gonio::sim
