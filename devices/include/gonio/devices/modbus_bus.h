#pragma once

// One Modbus bus (a TCP connection or a serial line) and its single I/O owner. A libmodbus context
// is not thread-safe, so every request goes through ModbusBus under its mutex; the axes (and the
// shutter) on one bus share one ModbusBus. Each request has a deadline and bounded retries with
// exponential backoff. After a timeout the link is re-opened (TCP) or drained until the line has
// been quiet (RTU), so that a late reply can never be read as the answer to the next request.
//
// Bus scheduler: status polls (RequestPolicy::poll) of every unit on the bus share one budget of
// polls per second (poll_budget_per_s: a rate, or a share of an RTU line's capacity); commands are
// never held back. Reconnect: a link that is lost (refused, reset, closed) is re-opened with
// exponential back-off for up to the address's outage window (outage_ms, default 10 s) before a
// request fails; link_generation() counts the re-established links so that a driver can re-read
// its drive's state after one.

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/devices/address.h"

namespace gonio::devices {

/// Timing of one request (taken from the drive's profile).
struct RequestPolicy {
    std::chrono::milliseconds response_timeout{500};
    int retries = 3;                        ///< Further attempts after the first.
    std::chrono::milliseconds backoff{20};  ///< Wait before the 2nd attempt; doubles each time.
    /// RTU: after a timeout, bytes are discarded until the line has been silent this long (a late
    /// reply arriving within it is dropped). 0 = the response timeout.
    std::chrono::milliseconds quiet{0};
    /// A status poll: waits for its slot in the bus's poll budget (commands do not).
    bool poll = false;
};

/// Counters since the bus was opened.
struct BusStats {
    std::uint64_t requests = 0;       ///< Requests sent (attempts, including retries).
    std::uint64_t retries = 0;        ///< Attempts after a failed one.
    std::uint64_t timeouts = 0;       ///< Attempts that timed out.
    std::uint64_t reconnects = 0;     ///< Links re-opened.
    std::uint64_t drained_bytes = 0;  ///< Bytes discarded after timeouts (RTU).
    std::uint64_t polls = 0;          ///< Requests sent as status polls.
    std::uint64_t link_losses = 0;    ///< Times the link was found lost.
    double poll_wait_s = 0;           ///< Total time polls waited for their budget slot.
};

class ModbusBus {
  public:
    /// Opens (connects) a bus. The error names the address.
    static Expected<std::shared_ptr<ModbusBus>> open(const BusAddress& address);
    /// The bus for `address` shared within this process (opened on first use, kept while used).
    static Expected<std::shared_ptr<ModbusBus>> shared(const std::string& address);

    ~ModbusBus();
    ModbusBus(const ModbusBus&) = delete;
    ModbusBus& operator=(const ModbusBus&) = delete;

    const BusAddress& address() const { return address_; }

    /// Function 3. `what` names the place in errors ("axis \"light\" reg 0x00CC").
    Expected<std::vector<std::uint16_t>> read_registers(int unit,
                                                        int wire_address,
                                                        int count,
                                                        const RequestPolicy& policy,
                                                        const std::string& what);
    /// Function 16 (one request, so 32-bit values are never torn).
    Expected<void> write_registers(int unit,
                                   int wire_address,
                                   const std::vector<std::uint16_t>& values,
                                   const RequestPolicy& policy,
                                   const std::string& what);
    /// Function 6.
    Expected<void> write_register(int unit,
                                  int wire_address,
                                  std::uint16_t value,
                                  const RequestPolicy& policy,
                                  const std::string& what);
    /// Function 1.
    Expected<bool> read_coil(int unit,
                             int wire_address,
                             const RequestPolicy& policy,
                             const std::string& what);
    /// Function 5.
    Expected<void> write_coil(
        int unit, int wire_address, bool on, const RequestPolicy& policy, const std::string& what);

    BusStats stats() const;
    /// Polls per second this bus allows (all units together).
    double poll_budget_per_s() const;
    /// Incremented each time a request succeeds after a lost link or a timeout: the device may
    /// have lost power meanwhile, so its state is worth re-reading.
    std::uint64_t link_generation() const;

    struct Impl;  ///< The libmodbus context and its lock (opaque).

  private:
    explicit ModbusBus(BusAddress address);
    BusAddress address_;
    std::unique_ptr<Impl> impl_;
};

/// "Modbus exception 6 (slave busy)" for a libmodbus errno, or strerror text.
std::string describe_modbus_errno(int err);

}  // namespace gonio::devices
