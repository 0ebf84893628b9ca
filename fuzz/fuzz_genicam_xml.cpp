// libFuzzer target: the GenICam XML reader, the node-map builder and the single-file zip reader
// accept any bytes and either succeed or return an error, never crash or recurse without bound.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "gonio/devices/genicam.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    namespace genicam = gonio::devices::genicam;
    const std::string text(reinterpret_cast<const char*>(data), size);
    if (auto map = genicam::NodeMap::parse(text)) {
        // Resolve every feature against an all-zero register space.
        map->set_port(genicam::RegisterPort{
            [](std::uint64_t, std::size_t n) -> gonio::Expected<std::vector<std::uint8_t>> {
                return std::vector<std::uint8_t>(n, 0);
            },
            [](std::uint64_t, const std::vector<std::uint8_t>&) -> gonio::Expected<void> {
                return {};
            }});
        for (const std::string& name : map->names()) {
            (void)map->get_number(name);
            (void)map->get_enum(name);
            (void)map->get_string(name);
        }
    }
    (void)genicam::unzip_single_file(std::vector<std::uint8_t>(data, data + size));
    return 0;
}
