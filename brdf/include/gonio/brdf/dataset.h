#pragma once

// Measured BRDF samples: the dataset that acquisition writes and fitting reads.
//
// On disk (docs/file-formats.md): CSV with a header; required columns
// theta_i,phi_i,theta_o,phi_o,r,g,b (radians; BRDF in 1/sr); optional sigma_r,sigma_g,sigma_b
// (one-sigma uncertainty, 1/sr), weight (>= 0) and flag (unsigned integer bit set, see SampleFlag);
// optional, all eight together, the path of an exposure taken while the arms moved (fly scans):
// theta_i_start,phi_i_start,theta_o_start,phi_o_start,theta_i_end,phi_i_end,theta_o_end,phi_o_end
// (radians; brdf/exposure_path.h).
// Columns may come in any order; unknown columns are an error. Lines starting with '#' are
// comments.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/coords.h"

namespace gonio::brdf {

/// Bits of Sample::flags.
enum SampleFlag : std::uint32_t {
    kFlagSaturated =
        1u << 0,  ///< Some pixels saturated even at the shortest exposure (value is a lower bound).
    kFlagHdr = 1u << 1,  ///< Value merged from an exposure bracket.
    kFlagReference =
        1u << 2,  ///< Re-measurement of the drift reference configuration (not a BRDF sample).
    kFlagRoi = 1u << 3,  ///< Inside the region of interest of the requesting scene.
};

struct Sample {
    double theta_i = 0, phi_i = 0, theta_o = 0, phi_o = 0;  ///< radians
    Rgbd value = Rgbd::Zero();                              ///< BRDF, 1/sr
    Rgbd sigma = Rgbd::Zero();  ///< one-sigma uncertainty, 1/sr (0 if unknown)
    double weight = 1.0;        ///< relative weight in a fit, >= 0
    std::uint32_t flags = 0;
    std::size_t line = 0;  ///< source line (1-based) when read from a file, else 0
    /// Fly scans: the directions at the start and at the end of the exposure (theta_i, phi_i,
    /// theta_o, phi_o, radians), between which the arms moved along great circles at constant
    /// speed; theta_i .. phi_o above are then the directions at mid-exposure and `value` the
    /// exposure's mean (brdf/exposure_path.h). False: the arms stood still during the exposure.
    bool has_path = false;
    std::array<double, 4> path_start{};
    std::array<double, 4> path_end{};

    Vec3d wi() const { return spherical_to_cartesian(theta_i, phi_i); }
    Vec3d wo() const { return spherical_to_cartesian(theta_o, phi_o); }
};

/// A row that was read but not accepted (DatasetReadOptions::keep_going), with the reason
/// ("theta_i = 1.7 outside [0, pi/2) (at or below the horizon)"; the column's name says which).
struct RejectedRow {
    std::size_t line = 0;
    std::string reason;
};

struct Dataset {
    std::string source;  ///< file path or a description
    std::vector<Sample> samples;
    bool has_sigma = false;
    bool has_weight = false;
    bool has_flags = false;
    /// The eight exposure-path columns are present (a sample without a path has its start and end
    /// equal to its angles).
    bool has_path = false;
    /// Rows the reader refused and skipped, in file order (only with
    /// DatasetReadOptions::keep_going; a strict read refuses the file instead).
    std::vector<RejectedRow> rejected;
};

/// Checks one sample against the rules of a valid measurement: finite values, value >= 0, sigma >=
/// 0, weight >= 0, theta in [0, pi/2) for both directions (at or below the horizon is rejected),
/// phi in
/// [-2 pi, 2 pi], the same for the start and end of an exposure path. Returns an empty string when valid, else the reason naming the field.
std::string validate_sample(const Sample& s);

/// Limits of the values a dataset CSV may hold (1/sr for values and sigmas): far above any
/// measurable reflectance (a mirror seen through a 1e-6 sr aperture reads 1e6 1/sr), low enough
/// that squares and sums of a million of them stay finite.
inline constexpr double kMaxSampleValue = 1e9;
inline constexpr double kMaxSampleWeight = 1e9;

/// How read_dataset_csv() treats a row it cannot accept.
struct DatasetReadOptions {
    /// false (strict): the first bad row is an error naming it. true: a bad row (a field that is
    /// not a number, not finite or outside its range; the wrong number of fields) is recorded in
    /// Dataset::rejected with its line and reason and skipped; the header stays strict.
    bool keep_going = false;
    /// With keep_going: more refused rows than this is an error (a file that is mostly wrong is
    /// not a dataset with a few bad rows).
    std::size_t max_rejected = 10000;
};

/// Reads a dataset CSV (implemented in samples_io.cpp). Strict by default: every problem is an
/// error and nothing is skipped silently. A missing file, a missing, unknown or repeated column, a
/// row with the wrong number of fields ("data.csv:17: 6 fields, the header has 7") and a field that
/// is not a number, not finite or outside its range ("data.csv:17:3: theta_o = 1.7 outside
/// [0, pi/2) (at or below the horizon)") are errors naming file:line[:column]. Ranges:
/// theta in [0, pi/2), phi in [-2 pi, 2 pi], r, g, b and sigmas in [0, kMaxSampleValue], weight
/// in [0, kMaxSampleWeight], flag an unsigned 32-bit integer. With options.keep_going the bad rows
/// are listed in Dataset::rejected instead (see DatasetReadOptions).
Expected<Dataset> read_dataset_csv(const std::string& path, const DatasetReadOptions& options = {});

/// Writes a dataset CSV with full double precision (%.17g); sigma/weight/flag columns when the
/// dataset has them. Writes to path + ".tmp" and renames, so a reader never sees a half-written
/// file.
Expected<void> write_dataset_csv(const std::string& path, const Dataset& data);

/// Formats one sample as a CSV row (no newline) with the columns write_dataset_csv() chooses for
/// `data`.
std::string format_sample_row(const Sample& s, const Dataset& layout);
/// The header line matching format_sample_row().
std::string dataset_csv_header(const Dataset& layout);

}  // namespace gonio::brdf
