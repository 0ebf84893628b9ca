#include "gonio/acquisition/point/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>

namespace gonio::acquisition {

std::string format_duration(double s) {
    if (!std::isfinite(s) || s < 0) {
        return "?";
    }
    const long long t = std::llround(s);
    char buf[32];
    if (t < 60) {
        std::snprintf(buf, sizeof buf, "%lld s", t);
    } else if (t < 3600) {
        std::snprintf(buf, sizeof buf, "%lld:%02lld", t / 60, t % 60);
    } else {
        std::snprintf(buf, sizeof buf, "%lld:%02lld:%02lld", t / 3600, (t / 60) % 60, t % 60);
    }
    return buf;
}

Progress::Progress(std::FILE* out, std::size_t total, std::size_t done, double planned_s)
    : out_(out),
      tty_(out != nullptr && ::isatty(::fileno(out)) == 1),
      total_(total),
      done_(done),
      start_done_(done),
      planned_s_(planned_s),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

double Progress::rate_per_s() const {
    const double el =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const std::size_t n = done_ - start_done_;
    return (n == 0 || el <= 0) ? 0.0 : static_cast<double>(n) / el;
}

double Progress::eta_s() const {
    const double r = rate_per_s();
    const std::size_t left = total_ - std::min(done_, total_);
    if (r > 0) {
        return static_cast<double>(left) / r;
    }
    return planned_s_;
}

void Progress::step() {
    ++done_;
    draw(false);
}

void Progress::draw(bool force) {
    if (out_ == nullptr) {
        return;
    }
    const auto now = std::chrono::steady_clock::now();
    const double pct =
        total_ ? 100.0 * static_cast<double>(done_) / static_cast<double>(total_) : 100;
    if (tty_) {
        if (!force && now - last_draw_ < std::chrono::milliseconds(100) && done_ < total_) {
            return;
        }
        const int width = 30;
        const int filled = static_cast<int>(width * pct / 100);
        std::string bar(static_cast<std::size_t>(filled), '#');
        bar.resize(width, '.');
        std::fprintf(out_,
                     "\r[%s] %zu/%zu %3.0f%%  %.1f/s  ETA %s   ",
                     bar.c_str(),
                     done_,
                     total_,
                     pct,
                     rate_per_s(),
                     format_duration(eta_s()).c_str());
        std::fflush(out_);
    } else {
        const int decile = static_cast<int>(pct / 10);
        if ((!force && decile == last_decile_ && now - last_draw_ < std::chrono::seconds(10)) ||
            done_ == last_line_done_) {
            return;
        }
        last_decile_ = decile;
        last_line_done_ = done_;
        std::fprintf(out_,
                     "progress %zu/%zu (%.0f%%), %.1f measurements/s, ETA %s\n",
                     done_,
                     total_,
                     pct,
                     rate_per_s(),
                     format_duration(eta_s()).c_str());
        std::fflush(out_);
    }
    last_draw_ = now;
}

void Progress::finish(const std::string& what) {
    if (out_ == nullptr) {
        return;
    }
    draw(true);
    if (tty_) {
        std::fprintf(out_, "\n");
    }
    std::fprintf(out_, "%s\n", what.c_str());
    std::fflush(out_);
}

}  // namespace gonio::acquisition
