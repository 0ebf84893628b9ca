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

#include "gonio/devices/modbus_codec.h"
#include "gonio/devices/request_retry.h"

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

/// How a failed libmodbus call ended, for the retry rules.
AttemptOutcome classify(int err) {
    if (err == EMBXILFUN || err == EMBXILADD || err == EMBXILVAL || err == EMBXSFAIL ||
        err == EMBXMEMPAR || err == EMBXGPATH) {
        return AttemptOutcome::kRefused;
    }
    if (err == EMBXSBUSY || err == EMBXACK || err == EMBXNACK || err == EMBXGTAR) {
        return AttemptOutcome::kBusy;
    }
    if (err == ETIMEDOUT) {
        return AttemptOutcome::kTimeout;
    }
    if (err == EMBBADCRC || err == EMBBADDATA || err == EMBBADEXC || err == EMBMDATA ||
        err == EMBBADSLAVE) {
        return AttemptOutcome::kGarbled;
    }
    return AttemptOutcome::kLinkLost;
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

/// Runs `op` (one libmodbus call returning < 0 on failure) under the retry and outage rules of
/// RequestRetry: this function does the I/O the rules ask for.
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
    RetryRules rules;
    rules.retries = policy.retries;
    rules.backoff = policy.backoff;
    rules.outage = std::chrono::milliseconds(address.outage_ms);
    rules.poll = policy.poll;
    RequestRetry retry(rules);
    const std::chrono::milliseconds quiet =
        policy.quiet.count() > 0 ? policy.quiet : policy.response_timeout;
    int last_err = 0;
    for (;;) {
        AttemptOutcome outcome = AttemptOutcome::kLinkLost;
        if (!impl.connect()) {
            last_err = errno;
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
                outcome = AttemptOutcome::kSuccess;
            } else {
                last_err = errno;
                outcome = classify(last_err);
            }
        }
        const auto now = std::chrono::steady_clock::now();
        const Decision d = retry.after(outcome, now);
        if (outcome == AttemptOutcome::kTimeout) {
            ++impl.stats.timeouts;
        }
        if (d.link_lost_now) {
            ++impl.stats.link_losses;
        }
        const std::string place =
            what + " (unit " + std::to_string(unit) + ", " + to_string(address) + "): ";
        switch (d.step) {
            case NextStep::kDone:
                if (d.new_generation) {
                    ++impl.generation;
                }
                return {};
            case NextStep::kFail:
                if (retry.failure() == Failure::kRefused) {
                    return make_error(place + describe_modbus_errno(last_err));
                }
                if (retry.failure() == Failure::kOutage) {
                    return make_error(place + "link lost: " + describe_modbus_errno(last_err) +
                                      " for " + std::to_string(retry.lost_for(now).count()) +
                                      " ms (" + std::to_string(retry.attempts()) +
                                      " attempts), longer than the outage window of " +
                                      std::to_string(address.outage_ms) + " ms");
                }
                return make_error(place + describe_modbus_errno(last_err) + " after " +
                                  std::to_string(retry.attempts()) + " attempts");
            case NextStep::kResyncThenRetry:
                impl.resync(address.kind, quiet);
                break;
            case NextStep::kReconnectThenRetry:
                impl.disconnect();
                break;
            case NextStep::kRetry:
                break;
        }
        ++impl.stats.retries;
        std::this_thread::sleep_for(d.wait);
    }
}

/// A request's register or coil range, checked before anything is sent: addresses 0..0xFFFF, a
/// quantity the function allows, and a range that ends within the address space (in 64 bits: no
/// sum wraps).
Expected<void> check_range(const std::string& what,
                           int unit,
                           const BusAddress& address,
                           long long wire_address,
                           long long count,
                           int max_count) {
    if (wire_address < 0 || wire_address > 0xFFFF || count < 1 || count > max_count ||
        wire_address + count > static_cast<long long>(modbus::kAddressSpace)) {
        return make_error(what + " (unit " + std::to_string(unit) + ", " + to_string(address) +
                          "): " + std::to_string(count) + " registers at wire address " +
                          std::to_string(wire_address) + " are not a Modbus range (addresses 0.." +
                          "65535, at most " + std::to_string(max_count) + " per request)");
    }
    return {};
}

}  // namespace

Expected<std::vector<std::uint16_t>> ModbusBus::read_registers(
    int unit, int wire_address, int count, const RequestPolicy& policy, const std::string& what) {
    if (auto c = check_range(what, unit, address_, wire_address, count, modbus::kMaxReadRegisters);
        !c) {
        return tl::unexpected(c.error());
    }
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
    if (auto c = check_range(what,
                             unit,
                             address_,
                             wire_address,
                             static_cast<long long>(values.size()),
                             modbus::kMaxWriteRegisters);
        !c) {
        return c;
    }
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
    if (auto c = check_range(what, unit, address_, wire_address, 1, 1); !c) {
        return c;
    }
    return run_request(*impl_, address_, unit, policy, what, [&](modbus_t* ctx) {
        return modbus_write_register(ctx, wire_address, value);
    });
}

Expected<bool> ModbusBus::read_coil(int unit,
                                    int wire_address,
                                    const RequestPolicy& policy,
                                    const std::string& what) {
    if (auto c = check_range(what, unit, address_, wire_address, 1, 1); !c) {
        return tl::unexpected(c.error());
    }
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
    if (auto c = check_range(what, unit, address_, wire_address, 1, 1); !c) {
        return c;
    }
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
