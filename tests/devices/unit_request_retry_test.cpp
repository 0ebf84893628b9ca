// The retry and outage rules of a Modbus request without a bus: attempts end as told, at times
// given by the test (no clock, no sleeps).

#include <gtest/gtest.h>

#include <chrono>
#include <vector>

#include "gonio/devices/request_retry.h"

namespace {

using gonio::devices::AttemptOutcome;
using gonio::devices::Decision;
using gonio::devices::Failure;
using gonio::devices::NextStep;
using gonio::devices::RequestRetry;
using gonio::devices::RetryRules;
using namespace std::chrono_literals;
using Clock = RequestRetry::Clock;

RetryRules rules(int retries, std::chrono::milliseconds outage, bool poll = false) {
    RetryRules r;
    r.retries = retries;
    r.backoff = 20ms;
    r.max_backoff = 1000ms;
    r.outage = outage;
    r.poll = poll;
    return r;
}

TEST(RequestRetry, FirstTimeSuccessIsDoneWithoutANewGeneration) {
    RequestRetry r(rules(3, 10s));
    const Decision d = r.after(AttemptOutcome::kSuccess, Clock::time_point{});
    EXPECT_EQ(d.step, NextStep::kDone);
    EXPECT_FALSE(d.new_generation);
    EXPECT_EQ(r.attempts(), 1);
    EXPECT_EQ(r.failure(), Failure::kNone);
}

TEST(RequestRetry, RefusalForGoodFailsAtOnce) {
    RequestRetry r(rules(3, 10s));
    const Decision d = r.after(AttemptOutcome::kRefused, Clock::time_point{});
    EXPECT_EQ(d.step, NextStep::kFail);
    EXPECT_EQ(r.failure(), Failure::kRefused);
    EXPECT_EQ(r.attempts(), 1);
}

TEST(RequestRetry, BusyIsRetriedWithDoublingWaitsThenFailsAfterRetriesPlusOneAttempts) {
    RequestRetry r(rules(3, 10s));
    Clock::time_point t{};
    std::vector<long> waits;
    for (int i = 0; i < 3; ++i) {
        const Decision d = r.after(AttemptOutcome::kBusy, t);
        ASSERT_EQ(d.step, NextStep::kRetry) << i;
        waits.push_back(static_cast<long>(d.wait.count()));
        t += d.wait;
    }
    EXPECT_EQ(waits, (std::vector<long>{20, 40, 80}));
    const Decision last = r.after(AttemptOutcome::kBusy, t);
    EXPECT_EQ(last.step, NextStep::kFail);
    EXPECT_EQ(r.failure(), Failure::kRetriesExhausted);
    EXPECT_EQ(r.attempts(), 4);
}

TEST(RequestRetry, TimeoutsAndGarbledRepliesResyncAndASuccessAfterATimeoutIsANewGeneration) {
    RequestRetry r(rules(3, 10s));
    EXPECT_EQ(r.after(AttemptOutcome::kGarbled, Clock::time_point{}).step,
              NextStep::kResyncThenRetry);
    EXPECT_EQ(r.after(AttemptOutcome::kTimeout, Clock::time_point{}).step,
              NextStep::kResyncThenRetry);
    const Decision d = r.after(AttemptOutcome::kSuccess, Clock::time_point{});
    EXPECT_EQ(d.step, NextStep::kDone);
    EXPECT_TRUE(d.new_generation);
    // A garbled reply alone is not a silence: no new generation.
    RequestRetry g(rules(3, 10s));
    (void)g.after(AttemptOutcome::kGarbled, Clock::time_point{});
    EXPECT_FALSE(g.after(AttemptOutcome::kSuccess, Clock::time_point{}).new_generation);
}

TEST(RequestRetry, WaitsDoubleUpToTheCap) {
    RequestRetry r(rules(20, 10s));
    std::vector<long> waits;
    for (int i = 0; i < 9; ++i) {
        waits.push_back(
            static_cast<long>(r.after(AttemptOutcome::kBusy, Clock::time_point{}).wait.count()));
    }
    EXPECT_EQ(waits, (std::vector<long>{20, 40, 80, 160, 320, 640, 1000, 1000, 1000}));
}

TEST(RequestRetry, LostLinkIsRetriedBeyondTheRetryCountUntilTheOutageWindowEnds) {
    RequestRetry r(rules(1, 2000ms));
    const Clock::time_point t0{};
    Clock::time_point t = t0;
    int losses_counted = 0;
    int attempts = 0;
    Decision d;
    do {
        d = r.after(AttemptOutcome::kLinkLost, t);
        losses_counted += d.link_lost_now ? 1 : 0;
        ++attempts;
        if (d.step != NextStep::kFail) {
            EXPECT_EQ(d.step, NextStep::kReconnectThenRetry);
            t += d.wait;
        }
    } while (d.step != NextStep::kFail && attempts < 100);
    EXPECT_EQ(r.failure(), Failure::kOutage);
    EXPECT_EQ(losses_counted, 1);  // one outage, counted once
    // 20+40+80+160+320+640 = 1260 ms, then 1000 ms more: at 2260 ms the 2 s window is over.
    EXPECT_EQ(attempts, 8);
    EXPECT_EQ(r.lost_for(t).count(), 2260);
}

TEST(RequestRetry, SuccessAfterALostLinkIsANewGeneration) {
    RequestRetry r(rules(0, 10s));
    const Decision lost = r.after(AttemptOutcome::kLinkLost, Clock::time_point{});
    EXPECT_TRUE(lost.link_lost_now);
    EXPECT_EQ(lost.step, NextStep::kReconnectThenRetry);
    const Decision d = r.after(AttemptOutcome::kSuccess, Clock::time_point{} + 5s);
    EXPECT_EQ(d.step, NextStep::kDone);
    EXPECT_TRUE(d.new_generation);
}

TEST(RequestRetry, NoOutageWindowFailsALostLinkAtOnce) {
    RequestRetry r(rules(3, 0ms));
    const Decision d = r.after(AttemptOutcome::kLinkLost, Clock::time_point{});
    EXPECT_EQ(d.step, NextStep::kFail);
    EXPECT_TRUE(d.link_lost_now);
    EXPECT_EQ(r.failure(), Failure::kOutage);
}

TEST(RequestRetry, SilentDriveIsWaitedForByPollsButNotByCommands) {
    // A command: two timeouts with retries = 1 fail.
    RequestRetry command(rules(1, 1000ms, /*poll=*/false));
    EXPECT_EQ(command.after(AttemptOutcome::kTimeout, Clock::time_point{}).step,
              NextStep::kResyncThenRetry);
    EXPECT_EQ(command.after(AttemptOutcome::kTimeout, Clock::time_point{}).step, NextStep::kFail);
    EXPECT_EQ(command.failure(), Failure::kRetriesExhausted);
    // A poll: after its retries the silence is an outage, waited for within the window.
    RequestRetry poll(rules(1, 1000ms, /*poll=*/true));
    Clock::time_point t{};
    EXPECT_FALSE(poll.after(AttemptOutcome::kTimeout, t).link_lost_now);
    t += 500ms;
    const Decision second = poll.after(AttemptOutcome::kTimeout, t);
    EXPECT_EQ(second.step, NextStep::kResyncThenRetry);
    EXPECT_TRUE(second.link_lost_now);
    t += 999ms;
    EXPECT_EQ(poll.after(AttemptOutcome::kTimeout, t).step, NextStep::kResyncThenRetry);
    t += 1ms;  // 1000 ms after the silence began
    const Decision over = poll.after(AttemptOutcome::kTimeout, t);
    EXPECT_EQ(over.step, NextStep::kFail);
    EXPECT_FALSE(over.link_lost_now);
    EXPECT_EQ(poll.failure(), Failure::kOutage);
    EXPECT_EQ(poll.attempts(), 4);
    // A busy poll is not a silence: it fails after its retries.
    RequestRetry busy(rules(1, 1000ms, /*poll=*/true));
    (void)busy.after(AttemptOutcome::kBusy, Clock::time_point{});
    EXPECT_EQ(busy.after(AttemptOutcome::kBusy, Clock::time_point{}).step, NextStep::kFail);
    EXPECT_EQ(busy.failure(), Failure::kRetriesExhausted);
}

}  // namespace
