// The tensor file codec (format in tensor_file.h).

#include "gonio/brdf/tensor_file.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "gonio/base/atomic_file.h"
#include "gonio/base/limits.h"

namespace gonio::brdf {

namespace {

constexpr char kMagic[12] = {'t', 'e', 'n', 's', 'o', 'r', '_', 'f', 'i', 'l', 'e', '\0'};
constexpr std::size_t kPreambleBytes = 12 + 2 + 4;

// Little-endian reads from a bounded buffer; every read checks the remaining length first.
class Cursor {
  public:
    Cursor(const std::uint8_t* bytes, std::size_t size) : bytes_(bytes), size_(size) {}
    bool has(std::size_t n) const { return n <= size_ - pos_; }
    /// An unsigned little-endian integer of n <= 8 bytes.
    std::uint64_t uint(std::size_t n) {
        std::uint64_t v = 0;
        for (std::size_t k = 0; k < n; ++k) {
            v |= static_cast<std::uint64_t>(bytes_[pos_ + k]) << (8 * k);
        }
        pos_ += n;
        return v;
    }
    void skip(std::size_t n) { pos_ += n; }
    std::string text(std::size_t n) {
        std::string s(reinterpret_cast<const char*>(bytes_ + pos_), n);
        pos_ += n;
        return s;
    }
    std::size_t pos() const { return pos_; }

  private:
    const std::uint8_t* bytes_;
    std::size_t size_;
    std::size_t pos_ = 0;
};

void put_uint(std::string* out, std::uint64_t v, std::size_t n) {
    for (std::size_t k = 0; k < n; ++k) {
        out->push_back(static_cast<char>((v >> (8 * k)) & 0xffu));
    }
}

// Names are shown in messages as printable ASCII only (a hostile name cannot garble a terminal).
std::string printable(const std::string& s) {
    std::string out;
    for (char c : s.substr(0, 64)) {
        const auto u = static_cast<unsigned char>(c);
        out.push_back(u >= 0x20 && u < 0x7f ? c : '?');
    }
    return s.size() > 64 ? out + "..." : out;
}

}  // namespace

std::size_t tensor_dtype_size(TensorDtype dtype) {
    switch (dtype) {
        case TensorDtype::kUInt8:
        case TensorDtype::kInt8:
            return 1;
        case TensorDtype::kUInt16:
        case TensorDtype::kInt16:
        case TensorDtype::kFloat16:
            return 2;
        case TensorDtype::kUInt32:
        case TensorDtype::kInt32:
        case TensorDtype::kFloat32:
            return 4;
        case TensorDtype::kUInt64:
        case TensorDtype::kInt64:
        case TensorDtype::kFloat64:
            return 8;
    }
    return 0;
}

const char* tensor_dtype_name(TensorDtype dtype) {
    switch (dtype) {
        case TensorDtype::kUInt8:
            return "uint8";
        case TensorDtype::kInt8:
            return "int8";
        case TensorDtype::kUInt16:
            return "uint16";
        case TensorDtype::kInt16:
            return "int16";
        case TensorDtype::kUInt32:
            return "uint32";
        case TensorDtype::kInt32:
            return "int32";
        case TensorDtype::kUInt64:
            return "uint64";
        case TensorDtype::kInt64:
            return "int64";
        case TensorDtype::kFloat16:
            return "float16";
        case TensorDtype::kFloat32:
            return "float32";
        case TensorDtype::kFloat64:
            return "float64";
    }
    return "invalid";
}

std::uint64_t TensorField::elements() const {
    std::uint64_t n = 1;
    for (std::uint64_t d : shape) {
        n *= d;
    }
    return n;
}

std::string TensorField::describe() const {
    std::string s = printable(name) + " " + tensor_dtype_name(dtype) + " [";
    for (std::size_t k = 0; k < shape.size(); ++k) {
        s += (k ? ", " : "") + std::to_string(shape[k]);
    }
    return s + "]";
}

std::vector<float> TensorField::as_float32() const {
    std::vector<float> out(data.size() / 4);
    for (std::size_t k = 0; k < out.size(); ++k) {
        const std::uint32_t bits = static_cast<std::uint32_t>(data[4 * k]) |
                                   static_cast<std::uint32_t>(data[4 * k + 1]) << 8 |
                                   static_cast<std::uint32_t>(data[4 * k + 2]) << 16 |
                                   static_cast<std::uint32_t>(data[4 * k + 3]) << 24;
        std::memcpy(&out[k], &bits, 4);
    }
    return out;
}

TensorField TensorField::float32(std::string name,
                                 std::vector<std::uint64_t> shape,
                                 const std::vector<float>& values) {
    TensorField f;
    f.name = std::move(name);
    f.dtype = TensorDtype::kFloat32;
    f.shape = std::move(shape);
    f.data.reserve(values.size() * 4);
    for (float v : values) {
        std::uint32_t bits = 0;
        std::memcpy(&bits, &v, 4);
        for (int k = 0; k < 4; ++k) {
            f.data.push_back(static_cast<std::uint8_t>((bits >> (8 * k)) & 0xffu));
        }
    }
    return f;
}

TensorField TensorField::uint8(std::string name,
                               std::vector<std::uint64_t> shape,
                               const std::vector<std::uint8_t>& values) {
    TensorField f;
    f.name = std::move(name);
    f.dtype = TensorDtype::kUInt8;
    f.shape = std::move(shape);
    f.data = values;
    return f;
}

const TensorField* TensorFile::find(const std::string& name) const {
    for (const TensorField& f : fields) {
        if (f.name == name) {
            return &f;
        }
    }
    return nullptr;
}

namespace {

/// The size, the magic and the version (1.0) of the file.
Expected<void> check_preamble(const std::uint8_t* bytes,
                              std::size_t size,
                              const std::string& label) {
    if (size < kPreambleBytes) {
        return make_error(label + ": " + std::to_string(size) +
                          " bytes, too short for a tensor file (the magic, version and field "
                          "count take 18; truncated?)");
    }
    if (size > kMaxTensorFileBytes) {
        return make_error(label + ": " + human_bytes(static_cast<double>(size)) +
                          ", above the largest tensor file read (" +
                          human_bytes(static_cast<double>(kMaxTensorFileBytes)) + ")");
    }
    if (std::memcmp(bytes, kMagic, sizeof kMagic) != 0) {
        return make_error(label +
                          ": not a tensor file (the first 12 bytes are not \"tensor_file\\0\")");
    }
    return {};
}

/// The byte count of a field's data, with every product checked against the file size (no
/// overflow). A dimension of size 0 makes the field empty whatever the others are: the check then
/// does not apply, so that its verdict cannot depend on the order of the dimensions.
Expected<std::uint64_t> field_bytes(const TensorField& f, std::size_t size, const std::string& at) {
    const bool empty = std::find(f.shape.begin(), f.shape.end(), 0) != f.shape.end();
    std::uint64_t nbytes = empty ? 0 : tensor_dtype_size(f.dtype);
    for (std::size_t d = 0; d < f.shape.size() && !empty; ++d) {
        const std::uint64_t n = f.shape[d];
        if (nbytes > size / n) {
            return make_error(at + ": dimension " + std::to_string(d) + " of size " +
                              std::to_string(n) + " makes the data larger than the file (" +
                              std::to_string(size) + " bytes)");
        }
        nbytes *= n;
    }
    return nbytes;
}

/// The header of a field after its name: dimensions, data type, offset and shape.
Expected<void> read_field_type(Cursor& in, const std::string& at, TensorField* f) {
    if (!in.has(2 + 1 + 8)) {
        return make_error(at + ": header truncated before its type and offset");
    }
    const auto ndim = static_cast<std::uint16_t>(in.uint(2));
    const auto dtype = static_cast<std::uint8_t>(in.uint(1));
    f->offset = in.uint(8);
    if (dtype < 1 || dtype > 11) {
        return make_error(at + ": unknown data type " + std::to_string(dtype) +
                          " (1-11: uint8, int8, uint16, int16, uint32, int32, uint64, int64, "
                          "float16, float32, float64)");
    }
    f->dtype = static_cast<TensorDtype>(dtype);
    if (ndim > kMaxTensorDims) {
        return make_error(at + ": " + std::to_string(ndim) + " dimensions (at most " +
                          std::to_string(kMaxTensorDims) + ")");
    }
    if (!in.has(std::size_t{8} * ndim)) {
        return make_error(at + ": header truncated in the shape");
    }
    for (std::uint16_t d = 0; d < ndim; ++d) {
        f->shape.push_back(in.uint(8));
    }
    return {};
}

/// One field: its header from the cursor, its data from the file (`where` names the field by
/// its number until its name is known; `names` holds the names seen so far).
Expected<TensorField> read_field(Cursor& in,
                                 const std::uint8_t* bytes,
                                 std::size_t size,
                                 const std::string& label,
                                 const std::string& where,
                                 std::set<std::string>& names) {
    if (!in.has(2)) {
        return make_error(where + ": header truncated at byte " + std::to_string(in.pos()));
    }
    const auto name_length = static_cast<std::uint16_t>(in.uint(2));
    if (name_length > kMaxTensorNameLength) {
        return make_error(where + ": name of " + std::to_string(name_length) + " bytes (at most " +
                          std::to_string(kMaxTensorNameLength) + ")");
    }
    if (!in.has(name_length)) {
        return make_error(where + ": header truncated in the name");
    }
    TensorField f;
    f.name = in.text(name_length);
    const std::string at = label + ": field \"" + printable(f.name) + "\"";
    if (!names.insert(f.name).second) {
        return make_error(at + ": the name appears twice");
    }
    if (auto ok = read_field_type(in, at, &f); !ok) {
        return tl::unexpected(ok.error());
    }
    auto nbytes = field_bytes(f, size, at);
    if (!nbytes) {
        return tl::unexpected(nbytes.error());
    }
    if (f.offset > size || *nbytes > size - f.offset) {
        return make_error(at + ": data of " + std::to_string(*nbytes) + " bytes at offset " +
                          std::to_string(f.offset) + " runs past the end of the file (" +
                          std::to_string(size) + " bytes)");
    }
    f.data.assign(bytes + f.offset, bytes + f.offset + *nbytes);
    return f;
}

}  // namespace

Expected<TensorFile> parse_tensor_file(const std::uint8_t* bytes,
                                       std::size_t size,
                                       const std::string& label) {
    if (auto ok = check_preamble(bytes, size, label); !ok) {
        return tl::unexpected(ok.error());
    }
    Cursor in(bytes, size);
    in.skip(sizeof kMagic);
    TensorFile file;
    file.version_major = static_cast<std::uint8_t>(in.uint(1));
    file.version_minor = static_cast<std::uint8_t>(in.uint(1));
    if (file.version_major != 1 || file.version_minor != 0) {
        return make_error(label + ": tensor file version " + std::to_string(file.version_major) +
                          "." + std::to_string(file.version_minor) + " (only 1.0 is defined)");
    }
    const auto n_fields = static_cast<std::uint32_t>(in.uint(4));
    if (n_fields > kMaxTensorFields) {
        return make_error(label + ": " + std::to_string(n_fields) + " fields (at most " +
                          std::to_string(kMaxTensorFields) + ")");
    }
    std::set<std::string> names;
    for (std::uint32_t i = 0; i < n_fields; ++i) {
        const std::string where =
            label + ": field " + std::to_string(i + 1) + " of " + std::to_string(n_fields);
        auto f = read_field(in, bytes, size, label, where, names);
        if (!f) {
            return tl::unexpected(f.error());
        }
        file.fields.push_back(std::move(*f));
    }
    // Data may not overlap the header (every offset is checked now that the header's end is known).
    for (const TensorField& f : file.fields) {
        if (!f.data.empty() && f.offset < in.pos()) {
            return make_error(label + ": field \"" + printable(f.name) + "\": data at offset " +
                              std::to_string(f.offset) + " overlaps the header (which ends at " +
                              std::to_string(in.pos()) + ")");
        }
    }
    return file;
}

std::string encode_tensor_file(const TensorFile& file) {
    std::size_t header = kPreambleBytes;
    for (const TensorField& f : file.fields) {
        header += 2 + f.name.size() + 2 + 1 + 8 + 8 * f.shape.size();
    }
    auto align8 = [](std::size_t n) { return (n + 7) / 8 * 8; };
    std::vector<std::size_t> offsets;
    std::size_t pos = align8(header);
    for (const TensorField& f : file.fields) {
        offsets.push_back(pos);
        pos = align8(pos + f.data.size());
    }
    std::string out(kMagic, sizeof kMagic);
    put_uint(&out, file.version_major, 1);
    put_uint(&out, file.version_minor, 1);
    put_uint(&out, file.fields.size(), 4);
    for (std::size_t i = 0; i < file.fields.size(); ++i) {
        const TensorField& f = file.fields[i];
        put_uint(&out, f.name.size(), 2);
        out += f.name;
        put_uint(&out, f.shape.size(), 2);
        put_uint(&out, static_cast<std::uint8_t>(f.dtype), 1);
        put_uint(&out, offsets[i], 8);
        for (std::uint64_t d : f.shape) {
            put_uint(&out, d, 8);
        }
    }
    for (std::size_t i = 0; i < file.fields.size(); ++i) {
        out.resize(offsets[i], '\0');
        out.append(reinterpret_cast<const char*>(file.fields[i].data.data()),
                   file.fields[i].data.size());
    }
    out.resize(align8(out.size()), '\0');
    return out;
}

Expected<TensorFile> read_tensor_file(const std::string& path) {
    Expected<std::string> bytes = read_input_file(path, kMaxTensorFileBytes);
    if (!bytes) {
        return tl::unexpected(bytes.error());
    }
    return parse_tensor_file(
        reinterpret_cast<const std::uint8_t*>(bytes->data()), bytes->size(), path);
}

Expected<void> write_tensor_file(const std::string& path, const TensorFile& file) {
    return write_file_atomic(path, encode_tensor_file(file));
}

}  // namespace gonio::brdf
