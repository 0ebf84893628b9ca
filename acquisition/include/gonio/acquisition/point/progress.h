#pragma once

// Campaign progress for the operator: a redrawn bar with rate and ETA on a terminal, plain lines
// (at most one per 10% or per 10 s) otherwise, so logs stay readable.

#include <chrono>
#include <cstdio>
#include <string>

namespace gonio::acquisition {

class Progress {
  public:
    /// `total` measurements planned, `done` already in the journal; `planned_s` the schedule's
    /// estimate of the remaining time (motion only), used until a rate is measured.
    Progress(std::FILE* out, std::size_t total, std::size_t done, double planned_s);
    /// One more measurement finished.
    void step();
    /// Final line (the bar is ended with a newline).
    void finish(const std::string& what);
    /// Estimated seconds left: measured rate once there is one, else the plan's estimate.
    double eta_s() const;
    double rate_per_s() const;
    bool tty() const { return tty_; }

  private:
    void draw(bool force);

    std::FILE* out_;
    bool tty_;
    std::size_t total_;
    std::size_t done_;
    std::size_t start_done_;
    double planned_s_;
    std::chrono::steady_clock::time_point start_;
    std::chrono::steady_clock::time_point last_draw_;
    int last_decile_ = -1;
    /// Measurements done when the last line was printed (no terminal): the same count is not
    /// printed twice.
    std::size_t last_line_done_ = static_cast<std::size_t>(-1);
};

/// "1:02:03" / "2:03" / "7 s".
std::string format_duration(double seconds);

}  // namespace gonio::acquisition
