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

#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/model.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/spec.h"
#include "gonio/report/html_report.h"
#include "gonio/report/plot.h"

namespace gonio::report {

namespace {

using Clock = std::chrono::steady_clock;

const char* kPage = R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width, initial-scale=1">
<title>TITLE</title><style>
*{box-sizing:border-box}body{font-family:sans-serif;max-width:1000px;margin:1em auto;padding:0 1em;color:#222}
h1{font-size:1.4em}#bar{height:18px;background:#eee;border:1px solid #bbb}#fill{height:100%;width:0;background:#3a7}
.grid{display:flex;flex-wrap:wrap;gap:1em}.grid figure{margin:0;flex:1 1 460px;max-width:100%}
img{max-width:100%;height:auto;border:1px solid #ddd}figcaption{font-size:.9em;color:#444}
#fit{font-family:monospace;white-space:pre-wrap;overflow-wrap:anywhere}
</style></head><body>
<h1>TITLE</h1>
<p id="progress">waiting for the first measurement</p>
<div id="bar"><div id="fill"></div></div>
<p id="latest"></p>
<div class="grid">
<figure id="in_plane-figure" style="display:none"><img id="in_plane" alt="in-plane plot of the data so far"><figcaption>In-plane slices of the data so far and the live fit: BRDF luminance Y [1/sr].</figcaption></figure>
<figure id="coverage-figure" style="display:none"><img id="coverage" alt="coverage of the angular domain"><figcaption>Coverage: outgoing directions and (theta_h, theta_d) of every measurement so far.</figcaption></figure>
<figure id="frame-figure" style="display:none"><img id="frame" alt="latest camera frame"><figcaption>Latest camera frame.</figcaption></figure>
</div>
<h2>Fit of the data so far</h2><p id="fit">no fit yet</p>
<script>
var shown = {};
function show(name, v) {
  if (v > 0 && shown[name] !== v) {
    shown[name] = v; document.getElementById(name).src = '/img/' + name + '.png?v=' + v;
    var fig = document.getElementById(name + '-figure'); if (fig) { fig.style.display = ''; }
  }
}
function tick() {
  fetch('/status.json', {cache: 'no-store'}).then(function (r) { return r.json(); }).then(function (s) {
    document.getElementById('progress').textContent = s.done + ' of ' + s.planned + ' measured (' +
      s.percent.toFixed(1) + ' %), ' + s.state + '; ' + s.rate_per_min.toFixed(1) + ' per minute; ETA ' + s.eta;
    document.getElementById('progress').setAttribute('data-done', s.done);
    document.getElementById('fill').style.width = s.percent + '%';
    document.getElementById('latest').textContent = s.latest;
    document.getElementById('fit').textContent = s.fit;
    show('in_plane', s.versions.in_plane); show('coverage', s.versions.coverage); show('frame', s.versions.frame);
  }).catch(function () {}).then(function () { setTimeout(tick, 1000); });
}
tick();
</script></body></html>
)";

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
    for (std::size_t p = s.find(from); p != std::string::npos; p = s.find(from, p + to.size())) {
        s.replace(p, from.size(), to);
    }
    return s;
}

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
    std::string state = "starting";
    std::atomic<std::size_t> done{0};
    std::atomic<std::size_t> planned{0};
    std::atomic<std::size_t> first_done{static_cast<std::size_t>(-1)};
    Clock::time_point first_done_at = Clock::now();
    std::atomic<std::uint64_t> version{0};

    // Rendered by the render thread, served by the HTTP threads.
    struct Rendered {
        std::map<std::string, std::shared_ptr<const std::vector<std::uint8_t>>> png;
        std::map<std::string, std::uint64_t> versions;
        std::string fit = "no fit yet";
        std::string latest;
    };
    std::mutex out_mu;
    Rendered out;

    std::mutex wake_mu;
    std::condition_variable wake;
    bool stopping = false;
    std::atomic<std::uint64_t> requests{0};
    std::atomic<std::uint64_t> renders{0};

    void render_loop();
    std::string status_json();
};

std::string LiveServer::Impl::status_json() {
    const std::size_t d = done.load();
    const std::size_t p = planned.load();
    std::string st;
    Clock::time_point t0;
    {
        std::lock_guard<std::mutex> lock(in_mu);
        st = state;
        t0 = first_done_at;
    }
    // Rate over this run's measurements (a resumed campaign starts with some done).
    const std::size_t d0 = first_done.load();
    double rate_per_s = 0;
    if (d0 != static_cast<std::size_t>(-1) && d > d0) {
        const double secs = std::chrono::duration<double>(Clock::now() - t0).count();
        rate_per_s = secs > 0 ? static_cast<double>(d - d0) / secs : 0;
    }
    const double eta =
        rate_per_s > 0 && p >= d ? static_cast<double>(p - d) / rate_per_s : std::nan("");
    nlohmann::json j;
    j["done"] = d;
    j["planned"] = p;
    j["percent"] = p > 0 ? 100.0 * static_cast<double>(d) / static_cast<double>(p) : 0.0;
    j["state"] = st;
    j["rate_per_min"] = rate_per_s * 60;
    j["eta"] = st == "running" ? duration_text(eta) : "-";
    j["elapsed_s"] = std::chrono::duration<double>(Clock::now() - started).count();
    std::lock_guard<std::mutex> lock(out_mu);
    j["versions"] = out.versions;
    j["fit"] = out.fit;
    j["latest"] = out.latest;
    return j.dump();
}

void LiveServer::Impl::render_loop() {
    // Below the campaign's priority: the pictures may lag, the measurements must not.
    (void)setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), 10);
    brdf::Dataset data;
    data.source = "live";
    data.has_sigma = true;
    std::uint64_t seen = 0;
    Clock::time_point last_fit = Clock::now() - std::chrono::hours(1);
    std::size_t fitted_at = 0;
    std::unique_ptr<brdf::Brdf> fit;
    while (true) {
        {
            std::unique_lock<std::mutex> lock(wake_mu);
            wake.wait_for(lock, std::chrono::duration<double>(options.render_interval_s), [&] {
                return stopping;
            });
            if (stopping) {
                return;
            }
        }
        const std::uint64_t v = version.load();
        if (v == seen) {
            continue;
        }
        seen = v;
        std::optional<Image> new_frame;
        {
            // Only what is new is copied: the campaign thread waits at most for this.
            std::lock_guard<std::mutex> lock(in_mu);
            data.samples.insert(data.samples.end(),
                                samples.begin() + static_cast<long>(data.samples.size()),
                                samples.end());
            if (frame) {
                new_frame = std::move(frame);
                frame.reset();
            }
        }
        Rendered r;
        {
            std::lock_guard<std::mutex> lock(out_mu);
            r = out;
        }
        const std::uint64_t n = renders.load() + 1;
        PlotOptions po;
        po.width = options.plot_width;
        const Clock::time_point now = Clock::now();
        if (data.samples.size() >= options.fit_min_samples && data.samples.size() > fitted_at &&
            now - last_fit >= std::chrono::duration<double>(options.fit_interval_s)) {
            last_fit = now;
            fitted_at = data.samples.size();
            auto spec = fitting::make_fit_spec(fitting::ModelOptions{});
            if (spec) {
                spec->options.max_samples = options.fit_max_samples;
                spec->options.num_threads = 1;
                auto res = fitting::fit(data, *spec);
                if (res && res->usable()) {
                    fit = brdf::make_analytic_brdf(res->model);
                    char buf[160];
                    std::snprintf(buf,
                                  sizeof buf,
                                  "on %zu samples: log RMSE (r g b) %.4g %.4g %.4g; %s\n",
                                  data.samples.size(),
                                  res->metrics.log_rmse[0],
                                  res->metrics.log_rmse[1],
                                  res->metrics.log_rmse[2],
                                  res->goodness.represents
                                      ? "the model represents the data"
                                      : "the model does NOT represent the data");
                    r.fit = buf + fit->describe();
                } else {
                    r.fit =
                        "fit on " + std::to_string(data.samples.size()) + " samples: " +
                        (res ? "did not converge: " + res->solver.message : res.error().message);
                }
            }
        }
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
            put("in_plane", plot_in_plane(data, fit.get(), po));
            put("coverage", plot_coverage(data, po));
            const brdf::Sample& s = data.samples.back();
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
            r.latest = buf;
        }
        if (new_frame) {
            put("frame", *new_frame);
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
    const std::string page = replace_all(kPage, "TITLE", html_escape(options.title));
    s.Get("/", [p, page](const httplib::Request&, httplib::Response& res) {
        ++p->requests;
        res.set_content(page, "text/html; charset=utf-8");
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

void LiveServer::publish_sample(const brdf::Sample& sample) {
    {
        std::lock_guard<std::mutex> lock(impl_->in_mu);
        impl_->samples.push_back(sample);
    }
    ++impl_->version;
}

void LiveServer::publish_frame(Image frame) {
    {
        std::lock_guard<std::mutex> lock(impl_->in_mu);
        impl_->frame = std::move(frame);
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
