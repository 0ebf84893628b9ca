#include "gonio/devices/request_retry.h"

#include <algorithm>

namespace gonio::devices {

RequestRetry::RequestRetry(const RetryRules& rules) : rules_(rules), next_wait_(rules.backoff) {}

bool RequestRetry::mark_lost(Clock::time_point now) {
    if (link_lost_) {
        return false;
    }
    link_lost_ = true;
    lost_since_ = now;
    return true;
}

bool RequestRetry::outage_over(Clock::time_point now) const {
    return now - lost_since_ >= rules_.outage;
}

std::chrono::milliseconds RequestRetry::lost_for(Clock::time_point now) const {
    if (!link_lost_) {
        return std::chrono::milliseconds(0);
    }
    return std::chrono::duration_cast<std::chrono::milliseconds>(now - lost_since_);
}

Decision RequestRetry::retry(NextStep step) {
    Decision d;
    d.step = step;
    d.wait = next_wait_;
    next_wait_ = std::min(rules_.max_backoff, next_wait_ * 2);
    return d;
}

Decision RequestRetry::fail(Failure f) {
    failure_ = f;
    Decision d;
    d.step = NextStep::kFail;
    return d;
}

Decision RequestRetry::after(AttemptOutcome outcome, Clock::time_point now) {
    ++attempts_;
    switch (outcome) {
        case AttemptOutcome::kSuccess: {
            Decision d;
            d.step = NextStep::kDone;
            // Back after an outage or a silence: the drive may have lost power meanwhile.
            d.new_generation = link_lost_ || timed_out_;
            return d;
        }
        case AttemptOutcome::kRefused:
            return fail(Failure::kRefused);
        case AttemptOutcome::kLinkLost: {
            const bool first = mark_lost(now);
            if (outage_over(now)) {
                Decision d = fail(Failure::kOutage);
                d.link_lost_now = first;
                return d;
            }
            Decision d = retry(NextStep::kReconnectThenRetry);
            d.link_lost_now = first;
            return d;
        }
        case AttemptOutcome::kBusy:
        case AttemptOutcome::kTimeout:
        case AttemptOutcome::kGarbled:
            break;
    }
    const bool timeout = outcome == AttemptOutcome::kTimeout;
    timed_out_ = timed_out_ || timeout;
    ++failures_;
    const NextStep step =
        outcome == AttemptOutcome::kBusy ? NextStep::kRetry : NextStep::kResyncThenRetry;
    if (failures_ <= rules_.retries) {
        return retry(step);
    }
    // Retries spent. A poll that keeps timing out is a drive (or line) that went silent: wait for
    // it within the outage window, like a lost link.
    if (rules_.poll && timeout && rules_.outage.count() > 0) {
        const bool first = mark_lost(now);
        Decision d = outage_over(now) ? fail(Failure::kOutage) : retry(step);
        d.link_lost_now = first;
        return d;
    }
    return fail(Failure::kRetriesExhausted);
}

}  // namespace gonio::devices
