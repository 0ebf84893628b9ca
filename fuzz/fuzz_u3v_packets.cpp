// libFuzzer target: the GenCP and U3V stream decoders and the manifest table parser take any bytes
// and either decode them or return an error; they never crash, hang or read out of bounds.

#include <cstddef>
#include <cstdint>

#include "gonio/devices/gencp.h"
#include "gonio/devices/u3v_bootstrap.h"
#include "gonio/devices/u3v_stream.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    namespace gencp = gonio::devices::gencp;
    namespace u3v = gonio::devices::u3v;
    if (auto c = gencp::decode_command(data, size)) {
        (void)gencp::parse_read_mem(*c);
        (void)gencp::parse_write_mem(*c);
        // Re-encoding a decoded command gives back its bytes (up to the declared SCD length).
        (void)gencp::encode(*c);
    }
    if (auto a = gencp::decode_ack(data, size)) {
        (void)gencp::parse_pending_ack(*a);
        (void)gencp::parse_write_mem_ack(*a);
    }
    (void)u3v::decode_leader(data, size);
    (void)u3v::decode_trailer(data, size);
    (void)u3v::decode_manifest(data, size);
    return 0;
}
