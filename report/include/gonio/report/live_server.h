#pragma once

// The live campaign page: a small read-only HTTP server (cpp-httplib) that shows a running
// campaign's progress and ETA, the latest measurement and camera frame, the coverage, the in-plane
// plot and the fit of the data so far. The page polls /status.json once a second and reloads the
// pictures when their version changes.
//
// Two kinds of campaign: a point campaign publishes each measurement (publish_sample) and its
// progress in configurations (publish_progress); an image campaign publishes its progress in light
// positions with the covered fraction of its table (publish_image_progress) and the coverage of
// the table's (theta_h, theta_d) cells (publish_coverage). Both publish camera frames
// (publish_frame); until one arrives the page says that no frame has been seen, and why when the
// campaign's detector gives none (LiveOptions::frame_note).
//
// Threads: the campaign thread only publishes (publish_*): a short critical section that appends
// to a vector or swaps a value, never waiting for a client or for a picture. A render thread (at
// lower priority) turns the published data into PNG pictures and a fit at most every
// render_interval_s / fit_interval_s and swaps them in; the HTTP threads serve the last swapped
// pictures. A client that never reads, or hundreds of open connections, hold HTTP threads only
// (bounded by the read/write timeouts), never the campaign.
//
// The end: finish() keeps the final state, the final fit and the campaign's report on the page
// until the server stops. A page whose server has gone says so ("campaign ended" when the last
// state it saw was the end, else "connection lost"), with the last state it saw.
//
// Routes: GET / (the page), /status.json, /img/in_plane.png, /img/coverage.png, /img/frame.png,
// /report.html (after finish() with a report).
// Everything else is 404; methods other than GET are refused (the page is read-only).

#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "gonio/base/error.h"
#include "gonio/brdf/dataset.h"
#include "gonio/report/image.h"
#include "gonio/report/plot.h"

namespace gonio::report {

struct LiveOptions {
    std::string title = "gonio campaign";
    double render_interval_s = 1.0;     ///< Pictures redrawn at most this often.
    double fit_interval_s = 5.0;        ///< The fit of the data so far redone at most this often.
    std::size_t fit_min_samples = 12;   ///< No fit before this many samples.
    std::size_t fit_max_samples = 400;  ///< Stratified reduction of the live fit.
    int plot_width = 640;
    int io_timeout_s = 2;  ///< Read and write timeout of one connection.
    /// Shown in place of the frame until the first one is published.
    std::string frame_note = "no camera frame yet";
};

/// "[ADDR:]PORT" -> (address, port): ADDR defaults to 127.0.0.1, PORT in [0, 65535] (0: a free
/// port chosen by the system). Error naming the text and the rule.
Expected<std::pair<std::string, int>> parse_listen_address(const std::string& spec);

class LiveServer {
  public:
    /// Binds host:port and starts serving; error naming the address when it cannot bind.
    static Expected<std::unique_ptr<LiveServer>> start(const std::string& host,
                                                       int port,
                                                       const LiveOptions& options = {});
    ~LiveServer();
    LiveServer(const LiveServer&) = delete;
    LiveServer& operator=(const LiveServer&) = delete;

    /// "http://HOST:PORT/" with the bound port.
    std::string url() const;
    int port() const;

    /// Campaign thread: measurements done of planned, and the state ("running", "completed",
    /// "paused", "stopped").
    void publish_progress(std::size_t done, std::size_t planned, const std::string& state);
    /// Campaign thread: one finished measurement.
    void publish_sample(const brdf::Sample& sample);
    /// Campaign thread: the latest camera frame (8-bit picture), moved in; the description (what
    /// the frame is and how its counts are shown) becomes its caption.
    void publish_frame(Image frame, std::string description = {});

    /// Campaign thread, image campaigns: light positions done of at most max_frames, the covered
    /// fraction of the table's valid bins and the target fraction that ends the campaign, the
    /// state as in publish_progress. The ETA is the sooner of the frame limit and the target at the
    /// coverage gained per frame over the last frames.
    void publish_image_progress(std::size_t frames_done,
                                std::size_t max_frames,
                                double coverage,
                                double coverage_target,
                                const std::string& state);
    /// Campaign thread, image campaigns: the coverage of the table so far, moved in (drawn by the
    /// render thread with plot_coverage_cells).
    void publish_coverage(CoverageCells cells);

    /// The page's title (shown from the next load of the page).
    void set_title(const std::string& title);

    /// The campaign has ended in `state` ("completed", "paused", "stopped", ...): the server goes
    /// on serving its final state until stop(), with one more fit on every sample (the final fit)
    /// and, when report_path names a file, that page at /report.html, linked from the live page.
    /// /status.json says "ended": true; the page says "campaign ended" instead of an ETA.
    void finish(const std::string& state, const std::string& report_path = {});
    bool ended() const;

    /// Stops serving and joins the threads (also done by the destructor).
    void stop();

    /// Requests answered so far (all routes).
    std::uint64_t requests_served() const;
    /// Times the pictures were redrawn.
    std::uint64_t renders() const;

  private:
    struct Impl;
    explicit LiveServer(std::unique_ptr<Impl> impl);
    std::unique_ptr<Impl> impl_;
};

}  // namespace gonio::report
