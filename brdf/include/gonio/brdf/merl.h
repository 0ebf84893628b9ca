#pragma once

// The MERL binary BRDF format (W. Matusik, H. Pfister, M. Brand, L. McMillan, "A Data-Driven
// Reflectance Model", SIGGRAPH 2003; the MERL BRDF database), read and written bit-exactly, and the
// same layout at any resolution (the gonio table, *.gtab). Full description:
// docs/file-formats-tables.md.
//
//   bytes 0..11   three little-endian int32: n_theta_h, n_theta_d, n_phi_d (MERL: 90, 90, 180)
//   bytes 12..    3 * n little-endian IEEE-754 doubles, n = n_theta_h n_theta_d n_phi_d: all red,
//   then
//                 all green, then all blue, each in flat index order i_p + n_p (i_d + n_d i_h)
//   values        f [1/sr] = stored * (1/1500, 1.15/1500, 1.66/1500) for (r, g, b); stored < 0
//   means
//                 "not measured"
//
// Files are read in one piece into memory; nothing else is allocated per entry.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/base/error.h"
#include "gonio/brdf/table.h"

namespace gonio::brdf {

/// Per-channel factors from stored values to 1/sr (r, g, b).
constexpr std::array<double, 3> kMerlScale = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

/// Size in bytes of a file of the given grid: 12 + 24 n.
std::size_t merl_file_size(const TableGrid& grid);

/// Which dimensions a reader accepts.
enum class MerlDims {
    kMerlOnly,  ///< Exactly 90 x 90 x 180 (*.binary, *.merl).
    kAny,       ///< Any positive dimensions up to kMaxTableDim each (*.gtab).
};

/// Largest dimension accepted for a *.gtab table (per axis).
constexpr int kMaxTableDim = 4096;

/// Decodes a file image. `name` is used in error messages (a path). Errors: short header, bad dims,
/// size not matching the dims (truncated or trailing bytes), NaN/Inf entries (the first one is
/// named with its channel and bin).
Expected<TabulatedBrdf> parse_merl(const std::uint8_t* data,
                                   std::size_t size,
                                   const std::string& name,
                                   MerlDims dims = MerlDims::kMerlOnly);

/// Reads a file in the MERL layout. Errors name the file and the problem: missing, a directory,
/// unreadable, and everything parse_merl() rejects.
Expected<TabulatedBrdf> read_merl(const std::string& path, MerlDims dims = MerlDims::kMerlOnly);

/// Encodes a table in the MERL layout (any grid; the stored values are written unchanged, so
/// reading then encoding reproduces the file byte for byte).
std::vector<std::uint8_t> encode_merl(const TabulatedBrdf& table);

/// Writes encode_merl(table) to path (through path + ".tmp" and a rename). A *.binary / *.merl path
/// requires the 90 x 90 x 180 grid and MERL's scale; a *.gtab path requires MERL's scale.
Expected<void> write_merl(const std::string& path, const TabulatedBrdf& table);

/// True for the extensions of tabulated files: .binary, .merl, .gtab (case-sensitive).
bool is_table_path(const std::string& path);

/// Reads a tabulated file by extension: .binary/.merl as MERL (90 x 90 x 180 only), .gtab any grid.
Expected<TabulatedBrdf> read_table_file(const std::string& path);

}  // namespace gonio::brdf
