#pragma once

// The "tensor file" container of Mitsuba and the RGL material database (W. Jakob et al., Mitsuba
// renderer, `TensorFile`; J. Dupuy and W. Jakob, "An Adaptive Parameterization for Efficient
// Material Acquisition and Rendering", SIGGRAPH Asia 2018). Little endian throughout:
//
//   bytes 0-11   magic "tensor_file\0"
//   byte  12, 13 version major, minor (1, 0)
//   bytes 14-17  u32 number of fields
//   per field    u16 name length, the name (no terminator), u16 number of dimensions, u8 data type,
//                u64 byte offset of the data from the start of the file, one u64 size per dimension
//   then the data of every field, row-major (the last dimension contiguous), at its offset.
//
// Data types, as Mitsuba numbers them (its `Struct::Type` and `tensor_io.py`): 1 uint8, 2 int8,
// 3 uint16, 4 int16, 5 uint32, 6 int32, 7 uint64, 8 int64, 9 float16, 10 float32, 11 float64.
//
// A pure codec (bytes <-> struct, no I/O) plus a reader and a writer of whole files. The parser is
// strict and names the file and the field in every refusal: a truncated header, a wrong magic or
// version, an unknown data type, a repeated field name, a field whose data lies past the end of the
// file or overlaps the header, and sizes whose product overflows or exceeds the limits below.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/base/error.h"

namespace gonio::brdf {

/// Element types of a tensor field (Mitsuba's numbering; 0 is invalid in every file).
enum class TensorDtype : std::uint8_t {
    kUInt8 = 1,     ///< unsigned 8-bit integer
    kInt8 = 2,      ///< signed 8-bit integer
    kUInt16 = 3,    ///< unsigned 16-bit integer
    kInt16 = 4,     ///< signed 16-bit integer
    kUInt32 = 5,    ///< unsigned 32-bit integer
    kInt32 = 6,     ///< signed 32-bit integer
    kUInt64 = 7,    ///< unsigned 64-bit integer
    kInt64 = 8,     ///< signed 64-bit integer
    kFloat16 = 9,   ///< IEEE 754 half precision
    kFloat32 = 10,  ///< IEEE 754 single precision
    kFloat64 = 11,  ///< IEEE 754 double precision
};

/// Bytes per element of a data type.
std::size_t tensor_dtype_size(TensorDtype dtype);
/// "float32", "uint8", ...
const char* tensor_dtype_name(TensorDtype dtype);

/// Largest tensor file gonio reads: the spectral anisotropic files of the RGL database are below
/// 100 MB; four times that leaves room without letting a header claim gigabytes.
constexpr std::size_t kMaxTensorFileBytes = std::size_t{400} << 20;
/// Most fields in one file (RGL's files have about ten).
constexpr std::uint32_t kMaxTensorFields = 256;
/// Most dimensions of one field (RGL's deepest has five).
constexpr std::uint16_t kMaxTensorDims = 16;
/// Longest field name.
constexpr std::uint16_t kMaxTensorNameLength = 1024;

/// One field: its name, element type, shape and data bytes (little endian, row-major).
struct TensorField {
    std::string name;
    TensorDtype dtype = TensorDtype::kFloat32;
    std::vector<std::uint64_t> shape;
    std::uint64_t offset = 0;  ///< where the data was read from (ignored when encoding)
    std::vector<std::uint8_t> data;

    /// Number of elements (product of the shape; 1 for a scalar with no dimensions).
    std::uint64_t elements() const;
    /// "rgb float32 [1, 8, 3, 32, 32]"
    std::string describe() const;
    /// The data as floats; only for float32 fields (checked by the caller through dtype).
    std::vector<float> as_float32() const;

    static TensorField float32(std::string name,
                               std::vector<std::uint64_t> shape,
                               const std::vector<float>& values);
    static TensorField uint8(std::string name,
                             std::vector<std::uint64_t> shape,
                             const std::vector<std::uint8_t>& values);
};

/// A parsed tensor file: its fields in file order.
struct TensorFile {
    std::uint8_t version_major = 1;
    std::uint8_t version_minor = 0;
    std::vector<TensorField> fields;

    /// The field of that name, or nullptr.
    const TensorField* find(const std::string& name) const;
};

/// Parses a tensor file held in memory; `label` (the file name) starts every error message.
Expected<TensorFile> parse_tensor_file(const std::uint8_t* bytes,
                                       std::size_t size,
                                       const std::string& label);

/// Encodes the fields in order: the header, then each field's data at an offset aligned to 8
/// bytes (as Mitsuba's writer aligns them), zero padding between.
std::string encode_tensor_file(const TensorFile& file);

/// Reads and parses a whole file (at most kMaxTensorFileBytes).
Expected<TensorFile> read_tensor_file(const std::string& path);

/// Writes encode_tensor_file(file) through gonio::AtomicFile.
Expected<void> write_tensor_file(const std::string& path, const TensorFile& file);

}  // namespace gonio::brdf
