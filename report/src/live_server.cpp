#include "gonio/report/live_server.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>
#include <vector>

// cpp-httplib (Debian libcpp-httplib-dev), header only; its warnings are not ours.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#include <httplib.h>
#pragma GCC diagnostic pop

#include "gonio/base/limits.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/spec.h"
#include "gonio/report/html_report.h"
#include "gonio/report/plot.h"

namespace gonio::report {

namespace {

using Clock = std::chrono::steady_clock;

const char* kPage = R"PAGE(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width, initial-scale=1">
<title>TITLE</title><style>
*{box-sizing:border-box}body{font-family:sans-serif;max-width:1000px;margin:1em auto;padding:0 1em;color:#222}
h1{font-size:1.4em}#bar{height:18px;background:#eee;border:1px solid #bbb}#fill{height:100%;width:0;background:#3a7}
.grid{display:flex;flex-wrap:wrap;gap:1em}.grid figure{margin:0;flex:1 1 460px;max-width:100%}
img{max-width:100%;height:auto;border:1px solid #ddd}figcaption{font-size:.9em;color:#444}
.note{border:1px dashed #bbb;padding:2em 1em;color:#555;text-align:center}
#fit{font-family:monospace;white-space:pre-wrap;overflow-wrap:anywhere}
.ended{border:1px solid #3a7;background:#efe;padding:.5em 1em}
</style></head><body>
<h1>TITLE</h1>
<p id="progress" data-state="starting">waiting for the first measurement</p>
<div id="bar"><div id="fill"></div></div>
<p id="ended" class="ended" style="display:none"></p>
<p id="latest"></p>
<div class="grid">
<figure id="in_plane-figure" style="display:none"><img id="in_plane" alt="in-plane plot of the data so far" onload="loaded(this)"><figcaption>In-plane slices of the data so far and the live fit: BRDF luminance Y [1/sr].</figcaption></figure>
<figure id="coverage-figure" style="display:none"><img id="coverage" alt="coverage of the angular domain" onload="loaded(this)"><figcaption id="coverage-caption"></figcaption></figure>
<figure id="frame-figure"><img id="frame" alt="latest camera frame" style="display:none" onload="loaded(this)"><p id="frame-note" class="note">FRAME_NOTE</p><figcaption id="frame-caption">Latest camera frame.</figcaption></figure>
</div>
<h2 id="fit-heading">Fit of the data so far</h2><p id="fit">no fit yet</p>
<script>
var shown = {};
var last = null;
function loaded(img) { img.setAttribute('data-natural-width', img.naturalWidth); }
function show(name, v) {
  if (v > 0 && shown[name] !== v) {
    shown[name] = v; var img = document.getElementById(name);
    img.src = '/img/' + name + '.png?v=' + v; img.style.display = '';
    var fig = document.getElementById(name + '-figure'); if (fig) { fig.style.display = ''; }
    var note = document.getElementById(name + '-note'); if (note) { note.style.display = 'none'; }
  }
}
function text(id, t) { if (t !== undefined) { document.getElementById(id).textContent = t; } }
function clock() { return new Date().toTimeString().substring(0, 8); }
function counted(s) {
  return s.done + ' of ' + s.planned + (s.mode === 'image' ? ' light positions' : ' measured');
}
function ended(s) {
  var e = document.getElementById('ended');
  e.textContent = 'Campaign ended: ' + s.state + '. The final fit is below. ';
  if (s.report) {
    var a = document.createElement('a'); a.id = 'report-link'; a.href = s.report;
    a.textContent = 'Campaign report'; e.appendChild(a);
  }
  e.style.display = '';
  text('fit-heading', 'Final fit');
}
function lost() {
  // The server is gone: say so with the last state seen, never a state that is not running.
  var p = document.getElementById('progress');
  var t;
  if (last && last.ended) {
    t = 'campaign ended (' + last.state + '); the live page\'s server has closed since (noticed ' + clock() + '); last state: ' + counted(last);
    p.setAttribute('data-state', 'ended');
  } else {
    t = 'connection lost: the live page\'s server did not answer at ' + clock() + '; ' +
        (last ? 'last state seen: ' + counted(last) : 'no state seen');
    p.setAttribute('data-state', 'connection lost');
  }
  p.textContent = t;
}
function tick() {
  fetch('/status.json', {cache: 'no-store'}).then(function (r) {
    if (!r.ok) { throw new Error('HTTP ' + r.status); }
    return r.json();
  }).then(function (s) {
    last = s;
    text('progress', s.progress);
    document.getElementById('progress').setAttribute('data-done', s.done);
    document.getElementById('progress').setAttribute('data-state', s.ended ? 'ended' : s.state);
    if (s.mode === 'image') {
      document.getElementById('progress').setAttribute('data-coverage', s.coverage_percent.toFixed(2));
    }
    document.getElementById('fill').style.width = Math.min(100, s.bar_percent) + '%';
    text('latest', s.latest); text('fit', s.fit);
    text('coverage-caption', s.captions.coverage); text('frame-caption', s.captions.frame);
    show('in_plane', s.versions.in_plane); show('coverage', s.versions.coverage); show('frame', s.versions.frame);
    if (s.ended) { ended(s); }
  }).catch(lost).then(function () { setTimeout(tick, 1000); });
}
tick();
</script></body></html>
)PAGE";

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
    for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) {
        s.replace(p, from.size(), to);
    }
    return s;
}

/// The page with its title and the note shown until the first camera frame.
std::string page_with(const std::string& title, const std::string& frame_note) {
    return replace_all(
        replace_all(kPage, "TITLE", html_escape(title)), "FRAME_NOTE", html_escape(frame_note));
}

/// The largest campaign report served at /report.html (its pictures are embedded).
constexpr std::size_t kMaxReportBytes = std::size_t{256} << 20;

std::string duration_text(double s) {
    if (!std::isfinite(s) || s < 0) {
        return "unknown";
    }
    char buf[64];
    const long t = std::lround(s);
    if (t >= 3600) {
        std::snprintf(buf, sizeof buf, "%ld h %02ld min", t / 3600, (t % 3600) / 60);
    } else if (t >= 60) {
        std::snprintf(buf, sizeof buf, "%ld min %02ld s", t / 60, t % 60);
    } else {
        std::snprintf(buf, sizeof buf, "%ld s", t);
    }
    return buf;
}

}  // namespace

Expected<std::pair<std::string, int>> parse_listen_address(const std::string& spec) {
    std::string host = "127.0.0.1";
    std::string port_text = spec;
    const auto colon = spec.rfind(':');
    if (colon != std::string::npos) {
        host = spec.substr(0, colon);
        port_text = spec.substr(colon + 1);
        if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
            host = host.substr(1, host.size() - 2);
        }
        if (host.empty()) {
            return make_error("--serve " + spec + ": empty address before ':' (form [ADDR:]PORT)");
        }
    }
    if (port_text.empty() || port_text.size() > 5 ||
        port_text.find_first_not_of("0123456789") != std::string::npos) {
        return make_error("--serve " + spec + ": port '" + port_text +
                          "' is not a number in [0, 65535] (form [ADDR:]PORT, 0 = any free port)");
    }
    const int port = std::stoi(port_text);
    if (port > 65535) {
        return make_error("--serve " + spec + ": port " + port_text + " above 65535");
    }
    return std::make_pair(host, port);
}

struct LiveServer::Impl {
    LiveOptions options;
    httplib::Server http;
    std::string host;
    int port = 0;
    std::thread http_thread;
    std::thread render_thread;
    Clock::time_point started = Clock::now();

    // Published by the campaign thread.
    std::mutex in_mu;
    std::vector<brdf::Sample> samples;
    std::optional<Image> frame;
    std::string frame_description;
    std::optional<CoverageCells> cells;
    std::string state = "starting";
    // Image campaigns: covered fraction, target, and (frames done, coverage) of the last frames.
    std::atomic<bool> image_mode{false};
    double coverage = 0;
    double coverage_target = 0;
    std::vector<std::pair<std::size_t, double>> coverage_history;
    std::atomic<std::size_t> done{0};
    std::atomic<std::size_t> planned{0};
    std::atomic<std::size_t> first_done{static_cast<std::size_t>(-1)};
    Clock::time_point first_done_at = Clock::now();
    std::atomic<std::uint64_t> version{0};
    // The campaign has ended (finish): its last state stays on the page with the final fit and
    // the report, read from report_path and served at /report.html.
    std::atomic<bool> ended{false};
    std::atomic<bool> final_fit_pending{false};
    std::string report_path;

    // The page, with its title (set_title may change it once the campaign's folder is known).
    std::mutex page_mu;
    std::string page;

    // Rendered by the render thread, served by the HTTP threads.
    struct Rendered {
        std::map<std::string, std::shared_ptr<const std::vector<std::uint8_t>>> png;
        std::map<std::string, std::uint64_t> versions;
        std::string fit = "no fit yet";
        std::string latest;
        std::string coverage_caption;
        std::string frame_caption = "Latest camera frame.";
    };
    std::mutex out_mu;
    Rendered out;

    std::mutex wake_mu;
    std::condition_variable wake;
    bool stopping = false;
    std::atomic<std::uint64_t> requests{0};
    std::atomic<std::uint64_t> renders{0};

    /// What the campaign thread published since the last render, besides the samples.
    struct Incoming {
        std::optional<Image> frame;
        std::string frame_description;
        std::optional<CoverageCells> cells;
    };
    /// When the live fit last ran, on how many samples, and what it gave.
    struct LiveFit {
        Clock::time_point last = Clock::now() - std::chrono::hours(1);
        std::size_t fitted_at = 0;
        std::unique_ptr<brdf::Brdf> brdf;
    };

    void render_loop();
    /// Waits for the next render interval; false when the server stops.
    bool wait_render_interval();
    /// Appends the new samples to `data` and takes the new frame and coverage cells.
    Incoming take_new_input(brdf::Dataset& data);
    /// Refits when enough new samples came and the fit interval passed (or the campaign ended);
    /// the result's summary into r.fit.
    void refit(const brdf::Dataset& data, LiveFit& live, Rendered& r);
    std::string status_json();
};

namespace {

/// What the progress line says: counts, state, rate and time left.
struct Progress {
    std::size_t done = 0;
    std::size_t planned = 0;
    bool image = false;
    bool ended = false;
    std::string state;
    double coverage = 0;
    double target = 0;
    double percent = 0;
    double rate_per_s = 0;
    std::string eta_text;
    std::string eta_basis;
};

/// What is left: the rest of the plan; for an image campaign the sooner of the frame limit and
/// the frames that reach the target at the coverage gained per frame lately. Sets the basis.
double work_left(const Progress& pr,
                 const std::vector<std::pair<std::size_t, double>>& history,
                 std::string* basis) {
    double left = pr.planned >= pr.done ? static_cast<double>(pr.planned - pr.done) : 0;
    *basis = "the plan";
    if (!pr.image) {
        return left;
    }
    *basis = "the frame limit";
    if (pr.coverage >= pr.target) {
        return 0;
    }
    if (history.size() >= 2) {
        const auto& first = history.front();
        const auto& last = history.back();
        const double gain_per_frame =
            last.first > first.first
                ? (last.second - first.second) / static_cast<double>(last.first - first.first)
                : 0;
        if (gain_per_frame > 0) {
            const double to_target = std::ceil((pr.target - pr.coverage) / gain_per_frame);
            if (to_target < left) {
                left = to_target;
                *basis = "the coverage target at the recent gain per frame";
            }
        }
    }
    return left;
}

/// The bar's fill and the progress line: an ended campaign's summary, an image campaign's frames
/// and coverage, or a point campaign's measurements.
void put_progress(const Progress& pr, nlohmann::json& j) {
    const double cov = pr.coverage;
    const double target = pr.target;
    const double coverage_bar = std::max(pr.percent, target > 0 ? 100 * cov / target : 0.0);
    char buf[400];
    if (pr.ended) {
        j["bar_percent"] = pr.image ? coverage_bar : pr.percent;
        if (pr.image) {
            j["coverage_percent"] = 100 * cov;
            j["target_percent"] = 100 * target;
            std::snprintf(buf,
                          sizeof buf,
                          "campaign ended (%s): %zu light positions; coverage %.1f %% of the "
                          "valid bins (target %.1f %%)",
                          pr.state.c_str(),
                          pr.done,
                          100 * cov,
                          100 * target);
        } else {
            std::snprintf(buf,
                          sizeof buf,
                          "campaign ended (%s): %zu of %zu measured (%.1f %%)",
                          pr.state.c_str(),
                          pr.done,
                          pr.planned,
                          pr.percent);
        }
    } else if (pr.image) {
        j["coverage_percent"] = 100 * cov;
        j["target_percent"] = 100 * target;
        // The campaign ends at the target or at the frame limit, whichever comes first.
        j["bar_percent"] = coverage_bar;
        std::snprintf(buf,
                      sizeof buf,
                      "%zu of at most %zu light positions; coverage %.1f %% of the valid bins "
                      "(target %.1f %%); %s; %.1f frames per minute; ETA %s (by %s)",
                      pr.done,
                      pr.planned,
                      100 * cov,
                      100 * target,
                      pr.state.c_str(),
                      pr.rate_per_s * 60,
                      pr.eta_text.c_str(),
                      pr.eta_basis.c_str());
    } else {
        j["bar_percent"] = pr.percent;
        std::snprintf(buf,
                      sizeof buf,
                      "%zu of %zu measured (%.1f %%), %s; %.1f per minute; ETA %s",
                      pr.done,
                      pr.planned,
                      pr.percent,
                      pr.state.c_str(),
                      pr.rate_per_s * 60,
                      pr.eta_text.c_str());
    }
    j["progress"] = buf;
}

/// The latest measurement's angles (degrees) and value.
std::string latest_text(const brdf::Sample& s) {
    char buf[200];
    std::snprintf(buf,
                  sizeof buf,
                  "latest measurement: theta_i %.1f, phi_i %.1f, theta_o %.1f, phi_o "
                  "%.1f deg; BRDF (r g b) %.4g %.4g %.4g 1/sr",
                  s.theta_i * 180 / brdf::kPi,
                  s.phi_i * 180 / brdf::kPi,
                  s.theta_o * 180 / brdf::kPi,
                  s.phi_o * 180 / brdf::kPi,
                  s.value[0],
                  s.value[1],
                  s.value[2]);
    return buf;
}

}  // namespace

std::string LiveServer::Impl::status_json() {
    Progress pr;
    pr.done = done.load();
    pr.planned = planned.load();
    pr.image = image_mode.load();
    Clock::time_point t0;
    std::vector<std::pair<std::size_t, double>> history;
    std::string report_path_copy;
    {
        std::lock_guard<std::mutex> lock(in_mu);
        pr.state = state;
        report_path_copy = report_path;
        t0 = first_done_at;
        pr.coverage = coverage;
        pr.target = coverage_target;
        history = coverage_history;
    }
    const std::size_t d = pr.done;
    const std::size_t p = pr.planned;
    // Rate over this run's measurements (a resumed campaign starts with some done).
    const std::size_t d0 = first_done.load();
    if (d0 != static_cast<std::size_t>(-1) && d > d0) {
        const double secs = std::chrono::duration<double>(Clock::now() - t0).count();
        pr.rate_per_s = secs > 0 ? static_cast<double>(d - d0) / secs : 0;
    }
    const double left = work_left(pr, history, &pr.eta_basis);
    const double eta = pr.rate_per_s > 0 ? left / pr.rate_per_s : std::nan("");
    pr.ended = ended.load();
    pr.eta_text = pr.state == "running" && !pr.ended ? duration_text(eta) : "-";
    pr.percent = p > 0 ? 100.0 * static_cast<double>(d) / static_cast<double>(p) : 0.0;
    nlohmann::json j;
    j["mode"] = pr.image ? "image" : "point";
    j["done"] = d;
    j["planned"] = p;
    j["percent"] = pr.percent;
    j["state"] = pr.state;
    j["ended"] = pr.ended;
    j["report"] = pr.ended && !report_path_copy.empty() ? "/report.html" : "";
    j["rate_per_min"] = pr.rate_per_s * 60;
    j["eta"] = pr.eta_text;
    j["eta_basis"] = pr.eta_basis;
    j["elapsed_s"] = std::chrono::duration<double>(Clock::now() - started).count();
    put_progress(pr, j);
    std::lock_guard<std::mutex> lock(out_mu);
    j["versions"] = out.versions;
    j["fit"] = out.fit;
    j["latest"] = out.latest;
    j["captions"] = {{"coverage", out.coverage_caption}, {"frame", out.frame_caption}};
    return j.dump();
}

bool LiveServer::Impl::wait_render_interval() {
    std::unique_lock<std::mutex> lock(wake_mu);
    wake.wait_for(
        lock, std::chrono::duration<double>(options.render_interval_s), [&] { return stopping; });
    return !stopping;
}

LiveServer::Impl::Incoming LiveServer::Impl::take_new_input(brdf::Dataset& data) {
    // Only what is new is copied: the campaign thread waits at most for this.
    Incoming in;
    std::lock_guard<std::mutex> lock(in_mu);
    data.samples.insert(data.samples.end(),
                        samples.begin() + static_cast<long>(data.samples.size()),
                        samples.end());
    if (frame) {
        in.frame = std::move(frame);
        frame.reset();
        in.frame_description = this->frame_description;
    }
    if (cells) {
        in.cells = std::move(cells);
        cells.reset();
    }
    return in;
}

void LiveServer::Impl::refit(const brdf::Dataset& data, LiveFit& live, Rendered& r) {
    const Clock::time_point now = Clock::now();
    // The campaign's end asks for one more fit, on every sample, whenever the last one was.
    const bool final_fit = final_fit_pending.exchange(false);
    if (data.samples.size() < options.fit_min_samples ||
        !(final_fit ||
          (data.samples.size() > live.fitted_at &&
           now - live.last >= std::chrono::duration<double>(options.fit_interval_s)))) {
        return;
    }
    live.last = now;
    live.fitted_at = data.samples.size();
    auto spec = fitting::make_fit_spec(fitting::ModelOptions{});
    if (!spec) {
        return;
    }
    spec->options.max_samples = options.fit_max_samples;
    spec->options.num_threads = 1;
    auto res = fitting::fit(data, *spec);
    if (res && res->usable()) {
        live.brdf = brdf::make_analytic_brdf(res->model);
        char buf[160];
        std::snprintf(buf,
                      sizeof buf,
                      "%son %zu samples: log RMSE (r g b) %.4g %.4g %.4g; %s\n",
                      final_fit ? "final fit " : "",
                      data.samples.size(),
                      res->metrics.log_rmse[0],
                      res->metrics.log_rmse[1],
                      res->metrics.log_rmse[2],
                      res->goodness.represents ? "the model represents the data"
                                               : "the model does NOT represent the data");
        r.fit = buf + live.brdf->describe();
    } else {
        r.fit = std::string(final_fit ? "final fit" : "fit") + " on " +
                std::to_string(data.samples.size()) + " samples: " +
                (res ? "did not converge: " + res->solver.message : res.error().message);
    }
}

void LiveServer::Impl::render_loop() {
    // Below the campaign's priority: the pictures may lag, the measurements must not.
    (void)setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 10);
    brdf::Dataset data;
    data.source = "live";
    data.has_sigma = true;
    std::uint64_t seen = 0;
    LiveFit live;
    while (wait_render_interval()) {
        const std::uint64_t v = version.load();
        if (v == seen) {
            continue;
        }
        seen = v;
        Incoming in = take_new_input(data);
        Rendered r;
        {
            std::lock_guard<std::mutex> lock(out_mu);
            r = out;
        }
        const std::uint64_t n = renders.load() + 1;
        PlotOptions po;
        po.width = options.plot_width;
        if (image_mode.load() && data.samples.empty()) {
            r.fit = ended.load() ? "The campaign has ended; its table is fitted by gonio fit on "
                                   "the campaign's dataset.csv."
                                 : "An image campaign fills a half/difference table; it is fitted "
                                   "when the campaign ends (gonio fit on the campaign's "
                                   "dataset.csv).";
        }
        refit(data, live, r);
        auto put = [&](const char* name, const Expected<Image>& img) {
            if (!img) {
                return;
            }
            auto png = encode_png(*img);
            if (png) {
                r.png[name] = std::make_shared<const std::vector<std::uint8_t>>(std::move(*png));
                r.versions[name] = n;
            }
        };
        if (!data.samples.empty()) {
            put("in_plane", plot_in_plane(data, live.brdf.get(), po));
            put("coverage", plot_coverage(data, po));
            r.coverage_caption =
                "Coverage: outgoing directions and (theta_h, theta_d) of every measurement so far.";
            r.latest = latest_text(data.samples.back());
        }
        if (in.cells) {
            put("coverage", plot_coverage_cells(*in.cells, {}, po, "so far"));
            r.coverage_caption =
                "Coverage of the half/difference table so far: fraction of the phi_d bins of each "
                "(theta_h, theta_d) cell holding a measured value.";
        }
        if (in.frame) {
            put("frame", *in.frame);
            r.frame_caption = in.frame_description.empty()
                                  ? "Latest camera frame (" + std::to_string(in.frame->width) +
                                        " x " + std::to_string(in.frame->height) + " px)."
                                  : in.frame_description;
        }
        {
            std::lock_guard<std::mutex> lock(out_mu);
            out = std::move(r);
        }
        renders.store(n);
    }
}

LiveServer::LiveServer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

LiveServer::~LiveServer() {
    stop();
}

Expected<std::unique_ptr<LiveServer>> LiveServer::start(const std::string& host,
                                                        int port,
                                                        const LiveOptions& options) {
    auto impl = std::make_unique<Impl>();
    impl->options = options;
    impl->host = host;
    Impl* p = impl.get();
    httplib::Server& s = impl->http;
    s.set_read_timeout(options.io_timeout_s, 0);
    s.set_write_timeout(options.io_timeout_s, 0);
    s.set_keep_alive_timeout(options.io_timeout_s);
    s.set_keep_alive_max_count(100);
    impl->page = page_with(options.title, options.frame_note);
    s.Get("/", [p](const httplib::Request&, httplib::Response& res) {
        ++p->requests;
        std::string page;
        {
            std::lock_guard<std::mutex> lock(p->page_mu);
            page = p->page;
        }
        res.set_content(page, "text/html; charset=utf-8");
        res.set_header("Cache-Control", "no-store");
    });
    s.Get("/report.html", [p](const httplib::Request&, httplib::Response& res) {
        ++p->requests;
        std::string path;
        {
            std::lock_guard<std::mutex> lock(p->in_mu);
            path = p->report_path;
        }
        auto bytes = path.empty() ? Expected<std::string>(make_error("no report"))
                                  : read_input_file(path, kMaxReportBytes);
        if (!p->ended.load() || !bytes) {
            res.status = 404;
            res.set_content("no report yet (it is written when the campaign ends)\n", "text/plain");
            return;
        }
        res.set_content(*bytes, "text/html; charset=utf-8");
        res.set_header("Cache-Control", "no-store");
    });
    s.Get("/status.json", [p](const httplib::Request&, httplib::Response& res) {
        ++p->requests;
        res.set_content(p->status_json(), "application/json");
        res.set_header("Cache-Control", "no-store");
    });
    s.Get(R"(/img/(in_plane|coverage|frame)\.png)",
          [p](const httplib::Request& req, httplib::Response& res) {
              ++p->requests;
              std::shared_ptr<const std::vector<std::uint8_t>> png;
              {
                  std::lock_guard<std::mutex> lock(p->out_mu);
                  auto it = p->out.png.find(req.matches[1]);
                  if (it != p->out.png.end()) {
                      png = it->second;
                  }
              }
              if (!png) {
                  res.status = 404;
                  res.set_content("not drawn yet\n", "text/plain");
                  return;
              }
              res.set_content(reinterpret_cast<const char*>(png->data()), png->size(), "image/png");
              res.set_header("Cache-Control", "no-store");
          });
    const int bound =
        port == 0 ? s.bind_to_any_port(host) : (s.bind_to_port(host, port) ? port : -1);
    if (bound <= 0) {
        return make_error("live page: cannot listen on " + host + ":" + std::to_string(port) +
                          " (address in use, or not an address of this machine)");
    }
    impl->port = bound;
    impl->http_thread = std::thread([p] { p->http.listen_after_bind(); });
    impl->render_thread = std::thread([p] { p->render_loop(); });
    return std::unique_ptr<LiveServer>(new LiveServer(std::move(impl)));
}

std::string LiveServer::url() const {
    const bool v6 = impl_->host.find(':') != std::string::npos;
    return "http://" + (v6 ? "[" + impl_->host + "]" : impl_->host) + ":" +
           std::to_string(impl_->port) + "/";
}

int LiveServer::port() const {
    return impl_->port;
}

void LiveServer::publish_progress(std::size_t done, std::size_t planned, const std::string& state) {
    {
        std::lock_guard<std::mutex> lock(impl_->in_mu);
        if (impl_->first_done.load() == static_cast<std::size_t>(-1)) {
            impl_->first_done_at = Clock::now();
            impl_->first_done.store(done);
        }
        impl_->state = state;
    }
    impl_->done.store(done);
    impl_->planned.store(planned);
    ++impl_->version;
}

void LiveServer::set_title(const std::string& title) {
    std::lock_guard<std::mutex> lock(impl_->page_mu);
    impl_->options.title = title;
    impl_->page = page_with(title, impl_->options.frame_note);
}

void LiveServer::finish(const std::string& state, const std::string& report_path) {
    {
        std::lock_guard<std::mutex> lock(impl_->in_mu);
        impl_->state = state;
        impl_->report_path = report_path;
    }
    impl_->final_fit_pending.store(true);
    impl_->ended.store(true);
    ++impl_->version;
    impl_->wake.notify_all();
}

bool LiveServer::ended() const {
    return impl_->ended.load();
}

void LiveServer::publish_sample(const brdf::Sample& sample) {
    {
        std::lock_guard<std::mutex> lock(impl_->in_mu);
        impl_->samples.push_back(sample);
    }
    ++impl_->version;
}

void LiveServer::publish_frame(Image frame, std::string description) {
    {
        std::lock_guard<std::mutex> lock(impl_->in_mu);
        impl_->frame = std::move(frame);
        impl_->frame_description = std::move(description);
    }
    ++impl_->version;
}

void LiveServer::publish_image_progress(std::size_t frames_done,
                                        std::size_t max_frames,
                                        double coverage,
                                        double coverage_target,
                                        const std::string& state) {
    // Frames whose gain sets the ETA's pace.
    constexpr std::size_t kGainFrames = 6;
    {
        std::lock_guard<std::mutex> lock(impl_->in_mu);
        impl_->image_mode.store(true);
        impl_->coverage = std::isfinite(coverage) ? coverage : 0;
        impl_->coverage_target = std::isfinite(coverage_target) ? coverage_target : 0;
        auto& h = impl_->coverage_history;
        if (h.empty() || h.back().first != frames_done) {
            h.emplace_back(frames_done, impl_->coverage);
            if (h.size() > kGainFrames) {
                h.erase(h.begin());
            }
        }
    }
    publish_progress(frames_done, max_frames, state);
}

void LiveServer::publish_coverage(CoverageCells cells) {
    {
        std::lock_guard<std::mutex> lock(impl_->in_mu);
        impl_->cells = std::move(cells);
    }
    ++impl_->version;
}

void LiveServer::stop() {
    if (!impl_) {
        return;
    }
    {
        std::lock_guard<std::mutex> lock(impl_->wake_mu);
        if (impl_->stopping) {
            return;
        }
        impl_->stopping = true;
    }
    impl_->wake.notify_all();
    impl_->http.stop();
    if (impl_->http_thread.joinable()) {
        impl_->http_thread.join();
    }
    if (impl_->render_thread.joinable()) {
        impl_->render_thread.join();
    }
}

std::uint64_t LiveServer::requests_served() const {
    return impl_->requests.load();
}

std::uint64_t LiveServer::renders() const {
    return impl_->renders.load();
}

}  // namespace gonio::report
