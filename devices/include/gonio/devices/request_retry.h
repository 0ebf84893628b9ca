#pragma once

// The retry and outage rules of one Modbus request, as a state machine without I/O and without a
// clock of its own: the bus (ModbusBus) makes an attempt, tells the machine how it ended and when,
// and does what the machine says next (wait, drain the line, reconnect, give up). The rules:
// - a refusal for good (illegal function, address or value; device failure; parity; no gateway
//   path) fails at once;
// - a transient refusal (busy, acknowledge, negative acknowledge, gateway target silent) is
//   retried as is; a timeout or a garbled reply is retried after a resync (late bytes drained);
//   both count against `retries`;
// - a lost link (refused, reset, closed) does not count against `retries`: it is reopened and
//   retried until it has been lost for the outage window;
// - a status poll whose retries all timed out is a drive that went silent: it is waited for like
//   a lost link, within the outage window;
// - waits between attempts start at `backoff` and double up to `max_backoff`;
// - a success after a lost link or a timeout starts a new link generation (the drive may have lost
//   power: drivers re-read its state).

#include <chrono>

namespace gonio::devices {

struct RetryRules {
    int retries = 3;  ///< Further attempts after the first (lost links aside).
    std::chrono::milliseconds backoff{20};
    std::chrono::milliseconds max_backoff{1000};
    std::chrono::milliseconds outage{10000};  ///< How long a lost link is waited for.
    bool poll = false;                        ///< A status poll (a silent drive is an outage).
};

/// How one attempt ended.
enum class AttemptOutcome {
    kSuccess,   ///< The reply came and is the answer.
    kRefused,   ///< Refused for good (exception 1, 2, 3, 4, 8 or 10).
    kBusy,      ///< Refused for now (exception 5, 6, 7 or 11).
    kTimeout,   ///< No reply within the response timeout.
    kGarbled,   ///< A reply that is not the answer (CRC, length, unit, function).
    kLinkLost,  ///< The link is gone (connection refused, reset, closed; device gone).
};

/// What the bus does next.
enum class NextStep {
    kDone,                ///< Return the answer.
    kFail,                ///< Return an error (see RequestRetry::failure()).
    kRetry,               ///< Wait `wait`, then attempt again.
    kResyncThenRetry,     ///< Discard late bytes (TCP: reopen), wait `wait`, attempt again.
    kReconnectThenRetry,  ///< Close the link, wait `wait`, reopen it and attempt again.
};

/// Why a request failed.
enum class Failure {
    kNone,              ///< It has not failed.
    kRefused,           ///< The device refused it for good.
    kRetriesExhausted,  ///< `retries` further attempts failed too.
    kOutage,            ///< The link (or a polled drive) was lost for the whole outage window.
};

struct Decision {
    NextStep step = NextStep::kRetry;
    std::chrono::milliseconds wait{0};  ///< Before the next attempt.
    bool link_lost_now = false;         ///< This attempt began an outage (count it once).
    bool new_generation = false;        ///< kDone after a lost link or a timeout.
};

class RequestRetry {
  public:
    using Clock = std::chrono::steady_clock;

    explicit RequestRetry(const RetryRules& rules);

    /// Records how an attempt ended at `now` and decides what comes next.
    Decision after(AttemptOutcome outcome, Clock::time_point now);

    int attempts() const { return attempts_; }
    Failure failure() const { return failure_; }
    /// How long the link has been lost at `now` (0 when it has not been).
    std::chrono::milliseconds lost_for(Clock::time_point now) const;

  private:
    /// Starts the outage clock at the first loss; true when this call started it.
    bool mark_lost(Clock::time_point now);
    bool outage_over(Clock::time_point now) const;
    Decision retry(NextStep step);
    Decision fail(Failure f);

    RetryRules rules_;
    int attempts_ = 0;
    int failures_ = 0;  ///< Failed attempts that count against rules_.retries.
    bool link_lost_ = false;
    bool timed_out_ = false;
    Clock::time_point lost_since_{};
    std::chrono::milliseconds next_wait_;
    Failure failure_ = Failure::kNone;
};

}  // namespace gonio::devices
