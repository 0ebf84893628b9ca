#include "gonio/devices/modbus_bus.h"

#include <modbus/modbus.h>
#include <sys/select.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <map>
#include <thread>

namespace gonio::devices {
namespace {

/// Modbus exception codes (Modbus Application Protocol V1.1b3, section 7) and their names.
const char* exception_name(int code) {
    switch (code) {
        case 1:
            return "illegal function";
        case 2:
            return "illegal data address";
        case 3:
            return "illegal data value";
        case 4:
            return "slave device failure";
        case 5:
            return "acknowledge";
        case 6:
            return "slave busy";
        case 7:
            return "negative acknowledge";
        case 8:
            return "memory parity error";
        case 10:
            return "gateway path unavailable";
        case 11:
            return "gateway target failed to respond";
        default:
            return "unknown exception";
    }
}

/// What to do after a failed attempt.
enum class Recovery {
    kGiveUp,     ///< The drive refused the request for good (illegal address, value, function).
    kRetry,      ///< Transient refusal (busy): retry as is.
    kResync,     ///< Timeout or garbled reply: discard anything late, then retry.
    kReconnect,  ///< The link is gone: reopen it, then retry.
};

Recovery classify(int err) {
    if (err == EMBXILFUN || err == EMBXILADD || err == EMBXILVAL || err == EMBXSFAIL ||
        err == EMBXMEMPAR || err == EMBXGPATH) {
        return Recovery::kGiveUp;
    }
    if (err == EMBXSBUSY || err == EMBXACK || err == EMBXNACK || err == EMBXGTAR) {
        return Recovery::kRetry;
    }
    if (err == ETIMEDOUT || err == EMBBADCRC || err == EMBBADDATA || err == EMBBADEXC ||
        err == EMBMDATA || err == EMBBADSLAVE) {
        return Recovery::kResync;
    }
    return Recovery::kReconnect;
}

}  // namespace

std::string describe_modbus_errno(int err) {
    if (err > MODBUS_ENOBASE && err <= MODBUS_ENOBASE + 11) {
        const int code = err - MODBUS_ENOBASE;
        return "Modbus exception " + std::to_string(code) + " (" + exception_name(code) + ")";
    }
    if (err == ETIMEDOUT) {
        return "no reply (timeout)";
    }
    return modbus_strerror(err);
}

struct ModbusBus::Impl {
    std::mutex mu;
    modbus_t* ctx = nullptr;
    bool connected = false;
    bool ever_connected = false;
    BusStats stats;
    std::atomic<std::uint64_t> generation{0};
    // Poll scheduling (own lock: a poll waits for its slot without holding the bus).
    std::mutex poll_mu;
    std::chrono::steady_clock::time_point next_poll = std::chrono::steady_clock::now();
    std::chrono::nanoseconds poll_interval{0};

    /// Reserves the next poll slot of the bus and waits for it.
    void wait_poll_slot() {
        std::chrono::steady_clock::time_point slot;
        {
            std::lock_guard<std::mutex> lock(poll_mu);
            const auto now = std::chrono::steady_clock::now();
            slot = std::max(now, next_poll);
            next_poll = slot + poll_interval;
        }
        const auto now = std::chrono::steady_clock::now();
        if (slot > now) {
            std::this_thread::sleep_until(slot);
            std::lock_guard<std::mutex> lock(mu);
            stats.poll_wait_s += std::chrono::duration<double>(slot - now).count();
        }
    }

    ~Impl() {
        if (ctx != nullptr) {
            modbus_close(ctx);
            modbus_free(ctx);
        }
    }

    bool connect() {
        if (connected) {
            return true;
        }
        modbus_close(ctx);
        if (modbus_connect(ctx) != 0) {
            return false;
        }
        if (ever_connected) {
            ++stats.reconnects;
        }
        connected = true;
        ever_connected = true;
        return true;
    }

    void disconnect() {
        modbus_close(ctx);
        connected = false;
    }

    /// After a timeout or a garbled reply. TCP: reopen the connection, so a late reply goes to a
    /// closed socket. RTU (no transaction ids): discard bytes until the line has been quiet for
    /// `quiet`, bounded, then flush.
    void resync(BusKind kind, std::chrono::milliseconds quiet) {
        if (kind == BusKind::kTcp) {
            disconnect();
            return;
        }
        const int fd = modbus_get_socket(ctx);
        if (fd < 0) {
            disconnect();
            return;
        }
        const auto bound = std::chrono::steady_clock::now() + quiet * 8;
        unsigned char buf[256];
        while (std::chrono::steady_clock::now() < bound) {
            fd_set set;
            FD_ZERO(&set);
            FD_SET(fd, &set);
            timeval tv{};
            tv.tv_sec = static_cast<long>(quiet.count() / 1000);
            tv.tv_usec = static_cast<long>((quiet.count() % 1000) * 1000);
            const int rc = ::select(fd + 1, &set, nullptr, nullptr, &tv);
            if (rc == 0) {
                break;  // Quiet for the whole window.
            }
            if (rc < 0) {
                if (errno == EINTR) {
                    continue;
                }
                disconnect();
                return;
            }
            const ssize_t n = ::read(fd, buf, sizeof buf);
            if (n <= 0) {
                disconnect();
                return;
            }
            stats.drained_bytes += static_cast<std::uint64_t>(n);
        }
        modbus_flush(ctx);
    }
};

ModbusBus::ModbusBus(BusAddress address) : address_(std::move(address)), impl_(new Impl) {}

ModbusBus::~ModbusBus() = default;

Expected<std::shared_ptr<ModbusBus>> ModbusBus::open(const BusAddress& address) {
    std::shared_ptr<ModbusBus> bus(new ModbusBus(address));
    modbus_t* ctx = nullptr;
    if (address.kind == BusKind::kTcp) {
        ctx = modbus_new_tcp(address.host.c_str(), address.port);
    } else {
        ctx = modbus_new_rtu(address.device.c_str(),
                             address.baud,
                             address.parity,
                             address.data_bits,
                             address.stop_bits);
    }
    if (ctx == nullptr) {
        return make_error(to_string(address) +
                          ": cannot create Modbus context: " + modbus_strerror(errno));
    }
    bus->impl_->ctx = ctx;
    bus->impl_->poll_interval = std::chrono::nanoseconds(
        static_cast<long long>(1e9 / gonio::devices::poll_budget_per_s(address)));
    modbus_set_error_recovery(ctx, MODBUS_ERROR_RECOVERY_NONE);
    if (!bus->impl_->connect()) {
        return make_error(to_string(address) + ": cannot connect: " + modbus_strerror(errno));
    }
    return bus;
}

Expected<std::shared_ptr<ModbusBus>> ModbusBus::shared(const std::string& address) {
    auto parsed = parse_bus_address(address);
    if (!parsed) {
        return tl::unexpected(parsed.error());
    }
    static std::mutex registry_mu;
    static std::map<std::string, std::weak_ptr<ModbusBus>> registry;
    // One owner per physical line: the key is the serial device or the host and port, whatever
    // the query keys say.
    const std::string key = parsed->kind == BusKind::kRtu
                                ? "rtu:" + parsed->device
                                : "tcp://" + parsed->host + ":" + std::to_string(parsed->port);
    std::lock_guard<std::mutex> lock(registry_mu);
    if (auto it = registry.find(key); it != registry.end()) {
        if (auto bus = it->second.lock()) {
            if (to_string(bus->address()) != to_string(*parsed)) {
                return make_error("address \"" + address + "\": the line is already open as \"" +
                                  to_string(bus->address()) +
                                  "\"; every unit on one line must use the same address (one "
                                  "owner, one serial format, one poll budget)");
            }
            return bus;
        }
    }
    auto bus = open(*parsed);
    if (!bus) {
        return bus;
    }
    registry[key] = *bus;
    return bus;
}

namespace {

/// Runs `op` (one libmodbus call returning < 0 on failure) with retries and recovery.
template <class Op>
Expected<void> run_request(ModbusBus::Impl& impl,
                           const BusAddress& address,
                           int unit,
                           const RequestPolicy& policy,
                           const std::string& what,
                           Op op) {
    if (policy.poll) {
        impl.wait_poll_slot();
    }
    std::lock_guard<std::mutex> lock(impl.mu);
    int last_err = 0;
    int attempts = 0;
    int failures = 0;  ///< Failed attempts other than a lost link (bounded by policy.retries).
    const std::chrono::milliseconds quiet =
        policy.quiet.count() > 0 ? policy.quiet : policy.response_timeout;
    // A lost link is retried with back-off for up to the outage window; everything else counts
    // against policy.retries.
    using Clock = std::chrono::steady_clock;
    bool link_lost = false;
    bool timed_out = false;
    Clock::time_point lost_since;
    auto backoff = policy.backoff;
    const auto max_backoff = std::chrono::milliseconds(1000);
    for (;;) {
        if (attempts > 0) {
            ++impl.stats.retries;
            std::this_thread::sleep_for(backoff);
            backoff = std::min(max_backoff, backoff * 2);
        }
        ++attempts;
        bool link_failed = false;
        if (!impl.connect()) {
            last_err = errno;
            link_failed = true;
        } else {
            modbus_set_slave(impl.ctx, unit);
            const auto ms = policy.response_timeout.count();
            modbus_set_response_timeout(impl.ctx,
                                        static_cast<uint32_t>(ms / 1000),
                                        static_cast<uint32_t>((ms % 1000) * 1000));
            ++impl.stats.requests;
            if (policy.poll) {
                ++impl.stats.polls;
            }
            errno = 0;
            if (op(impl.ctx) >= 0) {
                if (link_lost || timed_out) {
                    // Back after an outage or a silence: drivers re-read their drives' state.
                    ++impl.generation;
                }
                return {};
            }
            last_err = errno;
            switch (classify(last_err)) {
                case Recovery::kGiveUp:
                    return make_error(what + " (unit " + std::to_string(unit) + ", " +
                                      to_string(address) + "): " + describe_modbus_errno(last_err));
                case Recovery::kRetry:
                    ++failures;
                    break;
                case Recovery::kResync:
                    if (last_err == ETIMEDOUT) {
                        ++impl.stats.timeouts;
                        timed_out = true;
                    }
                    impl.resync(address.kind, quiet);
                    ++failures;
                    break;
                case Recovery::kReconnect:
                    impl.disconnect();
                    link_failed = true;
                    break;
            }
        }
        if (link_failed) {
            const auto now = Clock::now();
            if (!link_lost) {
                link_lost = true;
                lost_since = now;
                ++impl.stats.link_losses;
            }
            if (now - lost_since >= std::chrono::milliseconds(address.outage_ms)) {
                const auto lost_ms =
                    std::chrono::duration_cast<std::chrono::milliseconds>(now - lost_since);
                return make_error(
                    what + " (unit " + std::to_string(unit) + ", " + to_string(address) +
                    "): link lost: " + describe_modbus_errno(last_err) + " for " +
                    std::to_string(lost_ms.count()) + " ms (" + std::to_string(attempts) +
                    " attempts), longer than the outage window of " +
                    std::to_string(address.outage_ms) + " ms");
            }
            continue;
        }
        if (failures > policy.retries) {
            // A poll that keeps timing out while a move is under way is a drive (or line) that
            // went silent: wait for it within the outage window, like a lost link.
            if (policy.poll && last_err == ETIMEDOUT && address.outage_ms > 0) {
                const auto now = Clock::now();
                if (!link_lost) {
                    link_lost = true;
                    lost_since = now;
                    ++impl.stats.link_losses;
                }
                if (now - lost_since < std::chrono::milliseconds(address.outage_ms)) {
                    continue;
                }
            }
            break;
        }
    }
    return make_error(what + " (unit " + std::to_string(unit) + ", " + to_string(address) +
                      "): " + describe_modbus_errno(last_err) + " after " +
                      std::to_string(attempts) + " attempts");
}

}  // namespace

Expected<std::vector<std::uint16_t>> ModbusBus::read_registers(
    int unit, int wire_address, int count, const RequestPolicy& policy, const std::string& what) {
    std::vector<std::uint16_t> out(static_cast<size_t>(count));
    auto r = run_request(*impl_, address_, unit, policy, what, [&](modbus_t* ctx) {
        const int n = modbus_read_registers(ctx, wire_address, count, out.data());
        if (n >= 0 && n != count) {
            errno = EMBBADDATA;
            return -1;
        }
        return n;
    });
    if (!r) {
        return tl::unexpected(r.error());
    }
    return out;
}

Expected<void> ModbusBus::write_registers(int unit,
                                          int wire_address,
                                          const std::vector<std::uint16_t>& values,
                                          const RequestPolicy& policy,
                                          const std::string& what) {
    return run_request(*impl_, address_, unit, policy, what, [&](modbus_t* ctx) {
        return modbus_write_registers(
            ctx, wire_address, static_cast<int>(values.size()), values.data());
    });
}

Expected<void> ModbusBus::write_register(int unit,
                                         int wire_address,
                                         std::uint16_t value,
                                         const RequestPolicy& policy,
                                         const std::string& what) {
    return run_request(*impl_, address_, unit, policy, what, [&](modbus_t* ctx) {
        return modbus_write_register(ctx, wire_address, value);
    });
}

Expected<bool> ModbusBus::read_coil(int unit,
                                    int wire_address,
                                    const RequestPolicy& policy,
                                    const std::string& what) {
    std::uint8_t bit = 0;
    auto r = run_request(*impl_, address_, unit, policy, what, [&](modbus_t* ctx) {
        return modbus_read_bits(ctx, wire_address, 1, &bit);
    });
    if (!r) {
        return tl::unexpected(r.error());
    }
    return bit != 0;
}

Expected<void> ModbusBus::write_coil(
    int unit, int wire_address, bool on, const RequestPolicy& policy, const std::string& what) {
    return run_request(*impl_, address_, unit, policy, what, [&](modbus_t* ctx) {
        return modbus_write_bit(ctx, wire_address, on ? 1 : 0);
    });
}

double ModbusBus::poll_budget_per_s() const {
    return gonio::devices::poll_budget_per_s(address_);
}

std::uint64_t ModbusBus::link_generation() const {
    return impl_->generation.load();
}

BusStats ModbusBus::stats() const {
    std::lock_guard<std::mutex> lock(impl_->mu);
    return impl_->stats;
}

}  // namespace gonio::devices
