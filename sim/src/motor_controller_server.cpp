#include "gonio/sim/motor_controller_server.h"

#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>

#include "modbus_server_loops.h"

namespace gonio::sim {

namespace detail {

void LoopContext::log(const std::string& line) const {
    if (options.log != nullptr) {
        std::fprintf(options.log, "sim: %s\n", line.c_str());
        std::fflush(options.log);
    }
}

void LoopContext::drain_wake() const {
    char buf[64];
    while (::read(wake_fd, buf, sizeof buf) > 0) {
    }
}

}  // namespace detail

struct MotorControllerServer::Impl {
    MotorRegisters registers;
    ServerOptions options;
    std::mutex blip_mu;
    bool blip_pending = false;  ///< A simulated blip was requested (taken by the event loop).
    std::chrono::milliseconds blip_length{0};
    int listen_fd = -1;
    int pty_master = -1;
    int pty_slave_keep = -1;
    std::string pty_path;
    int bound_port = 0;
    int wake[2] = {-1, -1};
    std::thread thread;
    std::atomic<bool> running{false};

    ~Impl() { close_all(); }

    void close_all() {
        for (int* fd : {&listen_fd, &pty_master, &pty_slave_keep, &wake[0], &wake[1]}) {
            if (*fd >= 0) {
                ::close(*fd);
                *fd = -1;
            }
        }
    }

    /// Takes a pending blip request.
    std::optional<detail::Blip> take_blip() {
        std::lock_guard<std::mutex> lock(blip_mu);
        if (!blip_pending) {
            return std::nullopt;
        }
        blip_pending = false;
        return detail::Blip{detail::Clock::now() + blip_length, blip_length};
    }
};

MotorControllerServer::MotorControllerServer() : impl_(new Impl) {}

MotorControllerServer::~MotorControllerServer() {
    stop();
}

Expected<void> MotorControllerServer::add_unit(int unit,
                                               const devices::AxisProfile& profile,
                                               const MotorSimConfig& cfg) {
    return impl_->registers.add_unit(unit, profile, cfg);
}

Expected<void> MotorControllerServer::add_shutter(int unit, int coil) {
    return impl_->registers.add_shutter(unit, coil);
}

Expected<void> MotorControllerServer::start(const ServerOptions& options) {
    if (impl_->running) {
        return make_error("sim: server already running");
    }
    impl_->close_all();
    impl_->options = options;
    if (::pipe2(impl_->wake, O_NONBLOCK | O_CLOEXEC) != 0) {
        return make_error(std::string("sim: pipe: ") + std::strerror(errno));
    }
    if (options.transport == Transport::kTcp) {
        std::string err;
        impl_->listen_fd = detail::make_tcp_listener(options.port, &err);
        if (impl_->listen_fd < 0) {
            impl_->close_all();
            return make_error("sim: cannot listen on 127.0.0.1:" + std::to_string(options.port) +
                              ": " + err);
        }
        sockaddr_in sa{};
        socklen_t sl = sizeof sa;
        ::getsockname(impl_->listen_fd, reinterpret_cast<sockaddr*>(&sa), &sl);
        impl_->bound_port = ntohs(sa.sin_port);
    } else {
        const int m = ::posix_openpt(O_RDWR | O_NOCTTY);
        if (m < 0 || ::grantpt(m) != 0 || ::unlockpt(m) != 0) {
            if (m >= 0) {
                ::close(m);
            }
            return make_error(std::string("sim: pseudo-terminal: ") + std::strerror(errno));
        }
        impl_->pty_master = m;
        const char* name = ::ptsname(m);
        if (name == nullptr) {
            impl_->close_all();
            return make_error(std::string("sim: ptsname: ") + std::strerror(errno));
        }
        impl_->pty_path = name;
        termios tio{};
        ::tcgetattr(m, &tio);
        ::cfmakeraw(&tio);
        ::tcsetattr(m, TCSANOW, &tio);
        // Keep the slave side open so the master never sees a hang-up between clients; it is
        // never read (clients read their own descriptor).
        impl_->pty_slave_keep = ::open(name, O_RDWR | O_NOCTTY);
        if (impl_->pty_slave_keep >= 0) {
            termios st{};
            ::tcgetattr(impl_->pty_slave_keep, &st);
            ::cfmakeraw(&st);
            ::tcsetattr(impl_->pty_slave_keep, TCSANOW, &st);
        }
        ::fcntl(m, F_SETFL, ::fcntl(m, F_GETFL) | O_NONBLOCK);
    }
    impl_->running = true;
    detail::LoopContext ctx;
    ctx.registers = &impl_->registers;
    ctx.options = impl_->options;
    ctx.running = &impl_->running;
    ctx.wake_fd = impl_->wake[0];
    ctx.take_blip = [impl = impl_.get()] { return impl->take_blip(); };
    impl_->thread = std::thread([impl = impl_.get(), ctx] {
        if (ctx.options.transport == Transport::kTcp) {
            detail::serve_modbus_tcp(ctx, impl->listen_fd, impl->bound_port);
        } else {
            detail::serve_modbus_rtu(ctx, impl->pty_master);
        }
    });
    return {};
}

void MotorControllerServer::stop() {
    if (!impl_->running) {
        return;
    }
    impl_->running = false;
    const char c = 'x';
    (void)!::write(impl_->wake[1], &c, 1);
    if (impl_->thread.joinable()) {
        impl_->thread.join();
    }
    impl_->close_all();
}

bool MotorControllerServer::running() const {
    return impl_->running;
}

int MotorControllerServer::port() const {
    return impl_->bound_port;
}

std::string MotorControllerServer::device_path() const {
    return impl_->pty_path;
}

std::string MotorControllerServer::address() const {
    if (impl_->options.transport == Transport::kTcp) {
        return "tcp://127.0.0.1:" + std::to_string(impl_->bound_port);
    }
    return "rtu:" + impl_->pty_path + "?baud=" + std::to_string(impl_->options.baud) + "&parity=N";
}

void MotorControllerServer::blip(std::chrono::milliseconds down, bool drive_power_loss) {
    {
        std::lock_guard<std::mutex> lock(impl_->blip_mu);
        impl_->blip_pending = true;
        impl_->blip_length = down;
    }
    if (drive_power_loss) {
        impl_->registers.power_loss();
    }
    const char c = 'b';
    (void)!::write(impl_->wake[1], &c, 1);
}

void MotorControllerServer::inject(const Fault& f) {
    impl_->registers.inject(f);
}

void MotorControllerServer::clear_faults() {
    impl_->registers.clear_faults();
}

double MotorControllerServer::position_deg(int unit) const {
    return impl_->registers.position_deg(unit);
}

std::map<int, double> MotorControllerServer::positions_deg() const {
    return impl_->registers.positions_deg();
}

std::vector<double> MotorControllerServer::path_deg(int unit,
                                                    const std::vector<double>& after_s) const {
    return impl_->registers.path_deg(unit, after_s);
}

void MotorControllerServer::latch_exposure(int unit, double exposure_s) const {
    impl_->registers.latch_exposure(unit, exposure_s);
}

std::vector<ComparePulse> MotorControllerServer::take_pulses(bool* armed) {
    return impl_->registers.take_pulses(armed);
}

std::vector<double> MotorControllerServer::path_deg_at(int unit,
                                                       std::chrono::steady_clock::time_point at,
                                                       const std::vector<double>& after_s) const {
    return impl_->registers.path_deg_at(unit, at, after_s);
}

void MotorControllerServer::latch_pulse(int unit,
                                        std::size_t index,
                                        std::chrono::steady_clock::time_point at,
                                        double exposure_s) const {
    impl_->registers.latch_pulse(unit, index, at, exposure_s);
}

Expected<UnitSnapshot> MotorControllerServer::snapshot(int unit) const {
    return impl_->registers.snapshot(unit);
}

bool MotorControllerServer::shutter_open(int unit) const {
    return impl_->registers.shutter_open(unit);
}

std::uint64_t MotorControllerServer::request_count(int unit) const {
    return impl_->registers.request_count(unit);
}

void MotorControllerServer::set_time_scale(double time_scale) {
    impl_->registers.set_time_scale(time_scale);
}

}  // namespace gonio::sim
