#pragma once

// The campaign journal: append-only, one line per finished event (measurement, white reference,
// drift reference), written, flushed and fsynced before the campaign moves on. Each line is a JSON
// object followed by a tab, '#', and the 64-bit FNV-1a hash of the JSON text in hex, so that a line
// cut short by kill -9 or a power cut is recognised. On opening, a damaged last line (no newline or
// a wrong hash) is cut off: it was never acknowledged, so its measurement is repeated. A damaged
// line followed by good ones is corruption and an error.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/acquisition/shared/append_log.h"
#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::acquisition {

/// What a journal line records.
enum class RecordType {
    kMeasurement,  ///< A BRDF sample of the plan (pass, index).
    kWhite,        ///< The white-reference measurement (calibration).
    kReference,    ///< A re-measurement of the drift reference configuration on the sample.
    kNote,         ///< An event in words (pause, resume, drift accepted).
    /// A fly scan's sweep as it starts: pose_deg the lead-in, path_end_deg the lead-out, at
    /// speed_deg_per_s; its measurements follow (docs/operator-guide.md, "Fly scans").
    kSweep,
};

struct JournalRecord {
    RecordType type = RecordType::kMeasurement;
    int pass = 0;
    std::uint32_t index = 0;
    brdf::Vec3d wi = brdf::Vec3d::Zero();  ///< Measured directions (forward kinematics).
    brdf::Vec3d wo = brdf::Vec3d::Zero();
    std::array<double, 4> pose_deg{};       ///< light, detector, tilt, spin.
    brdf::Rgbd value = brdf::Rgbd::Zero();  ///< BRDF, 1/sr (kMeasurement, kReference).
    brdf::Rgbd sigma = brdf::Rgbd::Zero();
    brdf::Rgbd rate = brdf::Rgbd::Zero();  ///< Signal rate, counts/us at unit gain.
    brdf::Rgbd rate_sigma = brdf::Rgbd::Zero();
    std::uint32_t flags = 0;
    double weight = 1;
    double exposure_us = 0;
    double time_s = 0;  ///< Seconds since the Unix epoch.
    std::string text;   ///< kNote: the event.
    /// A measurement taken while an arm moved (fly scans): the poses the drive latched at the
    /// exposure's start and end (light, detector, tilt, spin, degrees); pose_deg, wi and wo are
    /// the pose at mid-exposure. kSweep: path_end_deg is the lead-out.
    bool has_path = false;
    std::array<double, 4> path_start_deg{};
    std::array<double, 4> path_end_deg{};
    double speed_deg_per_s = 0;  ///< kSweep: the arm's cruise speed.
};

/// FNV-1a, 64 bit, of a byte string.
std::uint64_t fnv1a64(const std::string& s);

std::string encode_record(const JournalRecord& r);               ///< One line, with hash and '\n'.
Expected<JournalRecord> decode_record(const std::string& line);  ///< Without the '\n'.

class Journal {
  public:
    /// Opens (creating if needed) the journal at `path`, reads its records, cuts off a damaged last
    /// line (reported through torn_tail()), and positions for appending.
    static Expected<Journal> open(const std::string& path);

    const std::vector<JournalRecord>& records() const { return records_; }
    bool torn_tail() const { return torn_tail_; }
    /// Writes the record, then fsync; the record is durable when this returns.
    Expected<void> append(const JournalRecord& r);
    const std::string& path() const { return log_.path(); }

  private:
    Journal() = default;
    AppendLog log_;
    std::vector<JournalRecord> records_;
    bool torn_tail_ = false;
};

}  // namespace gonio::acquisition
