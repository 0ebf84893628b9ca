// Single-file zip archives as GenCP manifests allow for the device description (PKWARE APPNOTE
// 6.3: end of central directory, central directory header, local file header; methods 0 stored
// and 8 deflate, inflated with zlib's raw inflate and checked against the CRC-32).

#include <zlib.h>

#include "gonio/devices/genicam.h"
#include "gonio/devices/u3v_bootstrap.h"

namespace gonio::devices::genicam {

using u3v::get_u16;
using u3v::get_u32;
using u3v::put_u16;
using u3v::put_u32;

namespace {
constexpr std::uint32_t kEocdSig = 0x06054b50;
constexpr std::uint32_t kCentralSig = 0x02014b50;
constexpr std::uint32_t kLocalSig = 0x04034b50;
constexpr std::size_t kMaxUncompressed = 64u << 20;
}  // namespace

Expected<std::string> unzip_single_file(const std::vector<std::uint8_t>& zip) {
    const std::size_t n = zip.size();
    if (n < 22) {
        return make_error("zip: " + std::to_string(n) +
                          " bytes, too short for an end-of-central-directory record");
    }
    // The EOCD record sits at the end, followed by a comment of at most 65535 bytes.
    std::size_t eocd = std::string::npos;
    const std::size_t lowest = n > 22 + 65535 ? n - 22 - 65535 : 0;
    for (std::size_t i = n - 22 + 1; i-- > lowest;) {
        if (get_u32(zip.data() + i) == kEocdSig) {
            eocd = i;
            break;
        }
    }
    if (eocd == std::string::npos) {
        return make_error("zip: no end-of-central-directory signature 0x06054b50");
    }
    const std::uint16_t entries = get_u16(zip.data() + eocd + 10);
    const std::uint32_t cd_offset = get_u32(zip.data() + eocd + 16);
    if (entries < 1) {
        return make_error("zip: the archive holds no file");
    }
    if (static_cast<std::uint64_t>(cd_offset) + 46 > n ||
        get_u32(zip.data() + cd_offset) != kCentralSig) {
        return make_error("zip: central directory offset " + std::to_string(cd_offset) +
                          " does not point to a central directory header");
    }
    const std::uint8_t* cd = zip.data() + cd_offset;
    const std::uint16_t method = get_u16(cd + 10);
    const std::uint32_t crc = get_u32(cd + 16);
    const std::uint32_t comp_size = get_u32(cd + 20);
    const std::uint32_t uncomp_size = get_u32(cd + 24);
    const std::uint32_t local = get_u32(cd + 42);
    if (uncomp_size > kMaxUncompressed) {
        return make_error("zip: uncompressed size " + std::to_string(uncomp_size) +
                          " exceeds the 64 MiB limit");
    }
    if (static_cast<std::uint64_t>(local) + 30 > n || get_u32(zip.data() + local) != kLocalSig) {
        return make_error("zip: local header offset " + std::to_string(local) +
                          " does not point to a local file header");
    }
    const std::uint64_t data_start = static_cast<std::uint64_t>(local) + 30 +
                                     get_u16(zip.data() + local + 26) +
                                     get_u16(zip.data() + local + 28);
    if (data_start + comp_size > n) {
        return make_error("zip: compressed data (" + std::to_string(comp_size) +
                          " bytes) runs past the end of the archive");
    }
    std::string out;
    if (method == 0) {
        // Stored.
        if (comp_size != uncomp_size) {
            return make_error("zip: stored entry with compressed size " +
                              std::to_string(comp_size) + " != uncompressed size " +
                              std::to_string(uncomp_size));
        }
        out.assign(reinterpret_cast<const char*>(zip.data() + data_start), comp_size);
    } else if (method == 8) {
        out.resize(uncomp_size);
        z_stream zs{};
        if (inflateInit2(&zs, -MAX_WBITS) != Z_OK) {
            return make_error("zip: zlib inflateInit2 failed");
        }
        zs.next_in = const_cast<Bytef*>(zip.data() + data_start);
        zs.avail_in = comp_size;
        zs.next_out = reinterpret_cast<Bytef*>(out.data());
        zs.avail_out = uncomp_size;
        const int rc = inflate(&zs, Z_FINISH);
        const uLong produced = zs.total_out;
        inflateEnd(&zs);
        if (rc != Z_STREAM_END || produced != uncomp_size) {
            return make_error("zip: deflate stream broken (zlib code " + std::to_string(rc) + ", " +
                              std::to_string(produced) + " of " + std::to_string(uncomp_size) +
                              " bytes)");
        }
    } else {
        return make_error("zip: compression method " + std::to_string(method) +
                          " is neither 0 (stored) nor 8 (deflate)");
    }
    const uLong actual =
        crc32(0L, reinterpret_cast<const Bytef*>(out.data()), static_cast<uInt>(out.size()));
    if (actual != crc) {
        return make_error("zip: CRC-32 mismatch (stored " + std::to_string(crc) + ", computed " +
                          std::to_string(actual) + ")");
    }
    return out;
}

Expected<std::vector<std::uint8_t>> zip_single_file(const std::string& file_name,
                                                    const std::string& contents) {
    std::vector<std::uint8_t> packed(compressBound(static_cast<uLong>(contents.size())) + 64);
    z_stream zs{};
    if (deflateInit2(&zs, Z_BEST_COMPRESSION, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY) !=
        Z_OK) {
        return make_error("zip: zlib deflateInit2 failed");
    }
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(contents.data()));
    zs.avail_in = static_cast<uInt>(contents.size());
    zs.next_out = packed.data();
    zs.avail_out = static_cast<uInt>(packed.size());
    const int rc = deflate(&zs, Z_FINISH);
    const uLong comp = zs.total_out;
    deflateEnd(&zs);
    if (rc != Z_STREAM_END) {
        return make_error("zip: deflate failed (zlib code " + std::to_string(rc) + ")");
    }
    packed.resize(comp);
    const std::uint32_t crc = static_cast<std::uint32_t>(crc32(
        0L, reinterpret_cast<const Bytef*>(contents.data()), static_cast<uInt>(contents.size())));
    const auto size = static_cast<std::uint32_t>(contents.size());
    const auto name_len = static_cast<std::uint16_t>(file_name.size());

    std::vector<std::uint8_t> out;
    put_u32(out, kLocalSig);
    put_u16(out, 20);    // version needed
    put_u16(out, 0);     // flags
    put_u16(out, 8);     // deflate
    put_u16(out, 0);     // time
    put_u16(out, 0x21);  // date 1980-01-01
    put_u32(out, crc);
    put_u32(out, static_cast<std::uint32_t>(comp));
    put_u32(out, size);
    put_u16(out, name_len);
    put_u16(out, 0);
    out.insert(out.end(), file_name.begin(), file_name.end());
    out.insert(out.end(), packed.begin(), packed.end());

    const auto cd_offset = static_cast<std::uint32_t>(out.size());
    put_u32(out, kCentralSig);
    put_u16(out, 20);  // version made by
    put_u16(out, 20);  // version needed
    put_u16(out, 0);
    put_u16(out, 8);
    put_u16(out, 0);
    put_u16(out, 0x21);
    put_u32(out, crc);
    put_u32(out, static_cast<std::uint32_t>(comp));
    put_u32(out, size);
    put_u16(out, name_len);
    put_u16(out, 0);  // extra
    put_u16(out, 0);  // comment
    put_u16(out, 0);  // disk
    put_u16(out, 0);  // internal attributes
    put_u32(out, 0);  // external attributes
    put_u32(out, 0);  // local header offset
    out.insert(out.end(), file_name.begin(), file_name.end());
    const auto cd_size = static_cast<std::uint32_t>(out.size() - cd_offset);

    put_u32(out, kEocdSig);
    put_u16(out, 0);
    put_u16(out, 0);
    put_u16(out, 1);
    put_u16(out, 1);
    put_u32(out, cd_size);
    put_u32(out, cd_offset);
    put_u16(out, 0);
    return out;
}

}  // namespace gonio::devices::genicam
