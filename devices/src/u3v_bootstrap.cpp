// Little-endian helpers and the manifest table codec (GenCP 1.x manifest, 64-byte entries).

#include "gonio/devices/u3v_bootstrap.h"

#include <cstring>

namespace gonio::devices::u3v {

void put_u16(std::vector<std::uint8_t>& out, std::uint16_t v) {
    out.push_back(static_cast<std::uint8_t>(v & 0xFF));
    out.push_back(static_cast<std::uint8_t>(v >> 8));
}

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) {
        out.push_back(static_cast<std::uint8_t>((v >> (8 * i)) & 0xFF));
    }
}

void put_u64(std::vector<std::uint8_t>& out, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) {
        out.push_back(static_cast<std::uint8_t>((v >> (8 * i)) & 0xFF));
    }
}

std::uint16_t get_u16(const std::uint8_t* p) {
    return static_cast<std::uint16_t>(p[0] | (static_cast<unsigned>(p[1]) << 8));
}

std::uint32_t get_u32(const std::uint8_t* p) {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) {
        v = (v << 8) | p[i];
    }
    return v;
}

std::uint64_t get_u64(const std::uint8_t* p) {
    std::uint64_t v = 0;
    for (int i = 7; i >= 0; --i) {
        v = (v << 8) | p[i];
    }
    return v;
}

std::string get_fixed_string(const std::uint8_t* p, std::size_t length) {
    std::size_t n = 0;
    while (n < length && p[n] != 0) {
        ++n;
    }
    return std::string(reinterpret_cast<const char*>(p), n);
}

std::vector<std::uint8_t> encode_manifest(const std::vector<ManifestEntry>& entries) {
    std::vector<std::uint8_t> out;
    put_u64(out, entries.size());
    for (const ManifestEntry& e : entries) {
        put_u32(out, e.file_version);
        put_u32(out, e.schema);
        put_u64(out, e.address);
        put_u64(out, e.size);
        out.insert(out.end(), e.sha1, e.sha1 + 20);
        out.insert(out.end(), 20, 0);
    }
    return out;
}

Expected<std::vector<ManifestEntry>> decode_manifest(const std::uint8_t* data, std::size_t size) {
    if (size < 8) {
        return make_error("manifest table: " + std::to_string(size) +
                          " bytes, need at least 8 for the entry count");
    }
    const std::uint64_t count = get_u64(data);
    // A device lists a handful of files; a huge count is a corrupt table.
    if (count == 0 || count > 64) {
        return make_error("manifest table: entry count " + std::to_string(count) +
                          " outside [1, 64]");
    }
    if (size < 8 + count * kManifestEntrySize) {
        return make_error("manifest table: " + std::to_string(count) + " entries need " +
                          std::to_string(8 + count * kManifestEntrySize) + " bytes, got " +
                          std::to_string(size));
    }
    std::vector<ManifestEntry> entries;
    for (std::uint64_t i = 0; i < count; ++i) {
        const std::uint8_t* p = data + 8 + i * kManifestEntrySize;
        ManifestEntry e;
        e.file_version = get_u32(p);
        e.schema = get_u32(p + 4);
        e.address = get_u64(p + 8);
        e.size = get_u64(p + 16);
        std::memcpy(e.sha1, p + 24, 20);
        const unsigned type = (e.schema >> 10) & 0x3F;
        if (type > 1) {
            return make_error("manifest entry " + std::to_string(i) + ": file type " +
                              std::to_string(type) + " is neither 0 (XML) nor 1 (zip)");
        }
        entries.push_back(e);
    }
    return entries;
}

}  // namespace gonio::devices::u3v
