#pragma once

// The image-mode frame journal: append-only, one record per finished light position, written and
// fsynced before the light arm moves on (as the point-mode journal, journal.h). A record holds what
// the frame added to the table, summarised per bin (image_binning.h: BinAggregate), so that a
// resumed campaign rebuilds exactly the table it held: no frame is lost and none is measured twice.
// The first record (the set-up) holds what the frames depend on: the table layout and the detector
// arm (checked on resume), the calibration constants and the fitted sample and reference spheres.
//
// Anisotropic campaigns (image_aniso.h) write their own record types: the set-up (3) adds the 4-D
// table layout to the set-up's fields, and each frame (4) records the holder's spin beside the
// light arm, the pole-cap pixel count, and per 4-D bin the mean directions instead of the mean
// half/difference position. A journal holds one kind or the other, never both.
//
// A frame taken through a zoomed camera placement (placement.h) is record type 5: the placement's
// number (u32, 1 for the rig's first zoomed placement), its magnification and its offset (three
// f64), then a type-2 payload. A resume checks them against the rig description's placements
// and takes off the candidates only that light position in that placement.
//
// Binary layout, little-endian: each record is
//   "GIJ1" | type (u8: 1 set-up, 2 frame, 3 anisotropic set-up, 4 anisotropic frame, 5 frame at
//   a zoomed placement) |
//   payload length (u32) | FNV-1a 64 of the payload (u64) | payload
// with doubles and floats as their IEEE 754 bit patterns. A record cut short (kill -9, power cut)
// or with a wrong hash at the end of the file was never acknowledged: it is cut off on opening and
// its frame measured again. A damaged record followed by good ones is corruption and an error.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gonio/acquisition/image/image_aniso.h"
#include "gonio/acquisition/image/image_binning.h"
#include "gonio/acquisition/image/sphere_geometry.h"
#include "gonio/acquisition/shared/append_log.h"
#include "gonio/base/error.h"

namespace gonio::acquisition {

/// The set-up record.
struct ImageJournalSetup {
    TableLayout layout;
    double detector_arm_rad = 0;
    std::array<double, 3> calibration{};  ///< Counts/us per 1/sr, per channel.
    SphereGeometry sphere;
    SphereGeometry reference_sphere;
    std::uint64_t captures = 0;  ///< Captures taken for the set-up (reference, silhouettes).
    double exposure_time_s = 0;
    /// An anisotropic campaign (record type 3) and its 4-D table.
    bool anisotropic = false;
    AnisoLayout aniso_layout;
};

/// One finished light position.
struct ImageJournalFrame {
    double light_arm_rad = 0;
    std::array<int, 3> exposures{};
    PixelCounts counts;
    double coverage_after = 0;
    bool bracketed = false;
    std::uint64_t captures = 0;  ///< Captures of this frame (dark frames included).
    double exposure_time_s = 0;  ///< Exposure time of this frame's captures.
    std::vector<BinAggregate> bins;
    /// An anisotropic campaign's frame (record type 4): the holder's spin and the 4-D bins.
    bool anisotropic = false;
    double spin_rad = 0;
    std::vector<AnisoBinAggregate> aniso_bins;
    /// The camera placement (record type 5; 0 the wide view) with its magnification and offset
    /// as they were when the frame was taken.
    int placement = 0;
    double magnification = 1;
    std::array<double, 2> offset_m{0, 0};
};

std::string encode_setup(const ImageJournalSetup& s);  ///< One whole record.
std::string encode_frame(const ImageJournalFrame& f);  ///< One whole record.

class ImageJournal {
  public:
    /// Opens (creating if needed) the journal, reads its records (checking every bin index against
    /// the set-up's layout, every frame's kind against the set-up's and every value for
    /// finiteness), cuts off a damaged last record (torn_tail()) and positions for appending.
    static Expected<ImageJournal> open(const std::string& path);

    const std::optional<ImageJournalSetup>& setup() const { return setup_; }
    /// The frames read back when the journal was opened (the frames appended since are on disk
    /// only: a campaign holds its table, not every frame's bins a second time).
    const std::vector<ImageJournalFrame>& frames() const { return frames_; }
    /// Frees the frames read back, once the campaign has merged them into its table.
    void release_frames() { std::vector<ImageJournalFrame>().swap(frames_); }
    bool torn_tail() const { return torn_tail_; }
    const std::string& path() const { return log_.path(); }

    /// Appends the set-up (only as the first record), then fsync.
    Expected<void> append_setup(const ImageJournalSetup& s);
    /// Appends a frame (after the set-up), then fsync: the frame is durable when this returns. It
    /// is not kept in frames().
    Expected<void> append_frame(const ImageJournalFrame& f);

  private:
    ImageJournal() = default;
    AppendLog log_;
    std::optional<ImageJournalSetup> setup_;
    std::vector<ImageJournalFrame> frames_;
    bool torn_tail_ = false;
};

}  // namespace gonio::acquisition
