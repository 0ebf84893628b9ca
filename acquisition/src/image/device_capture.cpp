#include <cmath>
#include <cstdio>
#include <memory>
#include <thread>

#include "gonio/acquisition/image/image_campaign.h"
#include "hdr_capture.h"

namespace gonio::acquisition {
namespace {

using detail::describe;

/// An arm of the pose and where the request wants it.
struct ArmCheck {
    devices::Axis* axis = nullptr;
    double target_deg = 0;
};

std::string format_deg(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4f", v);
    return buf;
}

/// The capture function over real devices (make_device_capture): what the devices were last set
/// to, so that only what a request changes is sent, and the pose checks around each exposure.
class DeviceCapture {
  public:
    DeviceCapture(devices::Camera& camera,
                  devices::Light& light,
                  devices::Axis& light_arm,
                  std::function<Expected<void>(int)> select_filter,
                  std::function<Expected<void>(bool)> swap_target,
                  const DeviceCaptureOptions& options)
        : camera_(&camera),
          light_(&light),
          light_arm_(&light_arm),
          select_filter_(std::move(select_filter)),
          swap_target_(std::move(swap_target)),
          o_(options),
          state_(std::make_shared<State>()) {}

    Expected<devices::Frame> operator()(const CaptureRequest& r) const {
        if (auto s = set_target(r); !s) {
            return tl::unexpected(s.error());
        }
        std::vector<ArmCheck> arms;
        if (auto a = pose_arms(r, &arms); !a) {
            return tl::unexpected(a.error());
        }
        if (auto v = set_view(r); !v) {
            return tl::unexpected(v.error());
        }
        if (auto s = set_optics(r); !s) {
            return tl::unexpected(s.error());
        }
        return checked_capture(r, arms);
    }

  private:
    struct State {
        bool have_light = false;
        double light_deg = 0;
        bool have_detector = false;
        bool have_spin = false;
        double spin_deg = 0;
        int filter = -1;
        int target = -1;  // 1 reference, 0 sample
        int placement = -1;
        double exposure_us = -1;
        int shutter = -1;
    };

    /// The white reference or the sample in place (swap_target when it changes).
    Expected<void> set_target(const CaptureRequest& r) const {
        const int target = r.reference ? 1 : 0;
        if (swap_target_ && state_->target != target) {
            if (auto s = swap_target_(r.reference); !s) {
                return tl::unexpected(s.error());
            }
            state_->target = target;
        }
        return {};
    }

    /// The arms the pose checks watch: the light arm, the detector arm and the spin when the rig
    /// has them under control.
    Expected<void> pose_arms(const CaptureRequest& r, std::vector<ArmCheck>* arms) const {
        arms->push_back({light_arm_, r.light_arm_rad * 180 / brdf::kPi});
        if (o_.detector_arm != nullptr) {
            arms->push_back({o_.detector_arm, o_.detector_arm_rad * 180 / brdf::kPi});
        }
        if (o_.spin != nullptr) {
            arms->push_back({o_.spin, r.spin_rad * 180 / brdf::kPi});
        } else if (r.spin_rad != 0) {
            return make_error(describe(r) + ": the rig gives this capture no spin axis");
        }
        return {};
    }

    /// The camera placement switched in when it changes.
    Expected<void> set_view(const CaptureRequest& r) const {
        if (state_->placement == r.placement) {
            return {};
        }
        if (o_.select_placement) {
            if (auto p = o_.select_placement(r.placement); !p) {
                return make_error(describe(r) + ": " + p.error().message);
            }
        } else if (r.placement != 0) {
            return make_error(describe(r) + ": the rig has no zoomed camera placement");
        }
        state_->placement = r.placement;
        return {};
    }

    /// Filter, shutter and exposure, each set when it changes.
    Expected<void> set_optics(const CaptureRequest& r) const {
        if (select_filter_ && state_->filter != r.channel) {
            if (auto f = select_filter_(r.channel); !f) {
                return tl::unexpected(f.error());
            }
            state_->filter = r.channel;
        }
        const int shutter = r.shutter_open ? 1 : 0;
        if (state_->shutter != shutter) {
            if (auto s = light_->set_shutter_open(r.shutter_open); !s) {
                return tl::unexpected(s.error());
            }
            state_->shutter = shutter;
        }
        if (state_->exposure_us != r.exposure_us) {
            if (auto e = camera_->set_exposure_us(r.exposure_us); !e) {
                return tl::unexpected(e.error());
            }
            state_->exposure_us = r.exposure_us;
        }
        return {};
    }

    /// The first moves: the light arm when its target changed, the detector arm on the first
    /// capture, the spin when its target changed.
    std::vector<bool> first_moves(const CaptureRequest& r,
                                  const std::vector<ArmCheck>& arms) const {
        std::vector<bool> move(arms.size(), false);
        move[0] = !state_->have_light || std::abs(state_->light_deg - arms[0].target_deg) > 1e-9;
        std::size_t k = 1;
        if (o_.detector_arm != nullptr) {
            move[k++] = !state_->have_detector;
        }
        if (o_.spin != nullptr) {
            const double spin_deg = r.spin_rad * 180 / brdf::kPi;
            move[k] = !state_->have_spin || std::abs(state_->spin_deg - spin_deg) > 1e-9;
        }
        return move;
    }

    /// The arms marked in `move` moved to their targets (then the settling time); the state
    /// records the pose as reached.
    Expected<void> move_arms(const CaptureRequest& r,
                             const std::vector<ArmCheck>& arms,
                             std::vector<bool>* move) const {
        bool moved_any = false;
        for (std::size_t k = 0; k < arms.size(); ++k) {
            if (!(*move)[k]) {
                continue;
            }
            if (auto m = arms[k].axis->move_to(arms[k].target_deg, o_.move_timeout); !m) {
                return tl::unexpected(m.error());
            }
            (*move)[k] = false;
            moved_any = true;
        }
        if (moved_any && o_.settle.count() > 0) {
            std::this_thread::sleep_for(o_.settle);
        }
        state_->have_light = true;
        state_->light_deg = arms[0].target_deg;
        state_->have_detector = true;
        state_->have_spin = true;
        state_->spin_deg = r.spin_rad * 180 / brdf::kPi;
        return {};
    }

    static Expected<void> read_back(const std::vector<ArmCheck>& arms, std::vector<double>* out) {
        out->clear();
        for (const ArmCheck& a : arms) {
            auto p = a.axis->position_deg();
            if (!p) {
                return tl::unexpected(p.error());
            }
            out->push_back(*p);
        }
        return {};
    }

    /// The arms read back away from their target by more than the tolerance, in words (marked
    /// to move back); empty when all are on target.
    std::string off_target(const std::vector<ArmCheck>& arms,
                           const std::vector<double>& before,
                           std::vector<bool>* move) const {
        std::string off;
        for (std::size_t k = 0; k < arms.size(); ++k) {
            if (std::abs(before[k] - arms[k].target_deg) > o_.pose_tolerance_deg) {
                off += (off.empty() ? "" : ", ") + arms[k].axis->name() + " at " +
                       format_deg(before[k]) + " deg, target " + format_deg(arms[k].target_deg) +
                       " deg";
                (*move)[k] = true;
            }
        }
        return off;
    }

    /// The arms that moved during the exposure, in words (marked to move back); empty when none.
    std::string moved_during(const std::vector<ArmCheck>& arms,
                             const std::vector<double>& before,
                             const std::vector<double>& after,
                             std::vector<bool>* move) const {
        std::string moved;
        for (std::size_t k = 0; k < arms.size(); ++k) {
            if (std::abs(after[k] - before[k]) > o_.pose_tolerance_deg) {
                moved += (moved.empty() ? "" : ", ") + arms[k].axis->name() + " " +
                         format_deg(before[k]) + " -> " + format_deg(after[k]) + " deg";
                (*move)[k] = true;
            }
        }
        return moved;
    }

    void note(const std::string& text, bool repeat) const {
        if (o_.log != nullptr) {
            (repeat ? o_.log->repeats : o_.log->corrections) += 1;
            o_.log->notes.push_back(text);
        }
    }

    /// The exposure with the pose checks around it (make_device_capture's comment): arms off
    /// target before it are moved back, arms that moved during it make it repeat, a camera error
    /// is retried.
    Expected<devices::Frame> checked_capture(const CaptureRequest& r,
                                             const std::vector<ArmCheck>& arms) const {
        std::vector<double> before;
        std::vector<double> after;
        int failures = 0;
        std::vector<bool> move = first_moves(r, arms);
        for (int attempt = 0;; ++attempt) {
            if (auto m = move_arms(r, arms, &move); !m) {
                return tl::unexpected(m.error());
            }
            if (auto b = read_back(arms, &before); !b) {
                return tl::unexpected(b.error());
            }
            if (const std::string off = off_target(arms, before, &move); !off.empty()) {
                if (attempt >= o_.max_pose_repeats) {
                    return make_error("pose check: the arms do not stay on target for the " +
                                      describe(r) + " (" + off + ") after " +
                                      std::to_string(attempt) + " corrections");
                }
                note("pose check: before the " + describe(r) + " " + off + "; moved back", false);
                continue;
            }
            auto frame = camera_->capture(capture_timeout(r, failures));
            if (!frame) {
                if (failures >= o_.capture_retries) {
                    return frame;
                }
                ++failures;
                if (o_.log != nullptr) {
                    ++o_.log->capture_retries;
                    o_.log->notes.push_back("camera error at the " + describe(r) + " (" +
                                            frame.error().message + "); captured again");
                }
                --attempt;  // Not a pose problem.
                continue;
            }
            if (auto a = read_back(arms, &after); !a) {
                return tl::unexpected(a.error());
            }
            const std::string moved = moved_during(arms, before, after, &move);
            if (moved.empty()) {
                return frame;
            }
            if (attempt >= o_.max_pose_repeats) {
                return make_error("pose check: the arms keep moving during the " + describe(r) +
                                  " (" + moved + ") after " + std::to_string(attempt) + " repeats");
            }
            note("pose check: an arm moved during the " + describe(r) + " (" + moved +
                     "); the capture is repeated",
                 true);
        }
    }

    /// The frame wait: the exposure beyond capture_timeout, doubled at each retry after a camera
    /// error (a frame that came late once, the camera busy or the host loaded, is set aside when
    /// it arrives: its stamp precedes the new trigger, and the new trigger's frame queues behind
    /// it).
    std::chrono::milliseconds capture_timeout(const CaptureRequest& r, int failures) const {
        return (o_.capture_timeout +
                std::chrono::milliseconds(static_cast<std::int64_t>(r.exposure_us / 1000))) *
               (1 << std::min(failures, 4));
    }

    devices::Camera* camera_;
    devices::Light* light_;
    devices::Axis* light_arm_;
    std::function<Expected<void>(int)> select_filter_;
    std::function<Expected<void>(bool)> swap_target_;
    DeviceCaptureOptions o_;
    std::shared_ptr<State> state_;
};

}  // namespace

CaptureFn make_device_capture(devices::Camera& camera,
                              devices::Light& light,
                              devices::Axis& light_arm,
                              std::function<Expected<void>(int)> select_filter,
                              std::function<Expected<void>(bool)> swap_target,
                              const DeviceCaptureOptions& options) {
    return DeviceCapture(
        camera, light, light_arm, std::move(select_filter), std::move(swap_target), options);
}

CaptureFn make_device_capture(devices::Camera& camera,
                              devices::Light& light,
                              devices::Axis& light_arm,
                              std::function<Expected<void>(int)> select_filter,
                              std::function<Expected<void>(bool)> swap_target,
                              std::chrono::milliseconds move_timeout) {
    DeviceCaptureOptions o;
    o.move_timeout = move_timeout;
    return make_device_capture(
        camera, light, light_arm, std::move(select_filter), std::move(swap_target), o);
}

}  // namespace gonio::acquisition
