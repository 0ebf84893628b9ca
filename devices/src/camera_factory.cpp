// Opens a camera from its address string.

#include "gonio/devices/camera_factory.h"

#include <cstdlib>
#include <map>
#include <mutex>

#include "gonio/devices/aravis_camera.h"
#include "gonio/devices/u3v_camera.h"
#include "gonio/devices/u3v_tcp.h"
#include "gonio/devices/usb_transport.h"
#include "gonio/devices/uvc_camera.h"

namespace gonio::devices {

namespace {

std::mutex& registry_mutex() {
    static std::mutex m;
    return m;
}

std::map<std::string, CameraOpener>& registry() {
    static std::map<std::string, CameraOpener> r;
    return r;
}

template <class T>
Expected<std::unique_ptr<Camera>> upcast(Expected<std::unique_ptr<T>> c) {
    if (!c) {
        return tl::unexpected(c.error());
    }
    return std::unique_ptr<Camera>(std::move(*c));
}

}  // namespace

void register_camera_scheme(const std::string& scheme, CameraOpener opener) {
    std::lock_guard<std::mutex> lock(registry_mutex());
    registry()[scheme] = std::move(opener);
}

Expected<std::unique_ptr<Camera>> open_camera(const std::string& address) {
    // GenICam cameras through Aravis.
    const std::string gige = "gige://";
    if (address.rfind(gige, 0) == 0) {
        return upcast(AravisCamera::open_gige(address.substr(gige.size())));
    }
    const std::string u3v = "u3v://";
    if (address.rfind(u3v, 0) == 0) {
        return upcast(AravisCamera::open_u3v(address.substr(u3v.size())));
    }
    const std::string aravis = "aravis:";
    if (address.rfind(aravis, 0) == 0) {
        return upcast(AravisCamera::open_id(address.substr(aravis.size())));
    }
    const std::string tcp = "u3v-tcp://";
    if (address.rfind(tcp, 0) == 0) {
        const std::string rest = address.substr(tcp.size());
        const std::size_t colon = rest.rfind(':');
        if (colon == std::string::npos) {
            return make_error("camera address '" + address + "': expected u3v-tcp://HOST:PORT");
        }
        char* end = nullptr;
        const long port = std::strtol(rest.c_str() + colon + 1, &end, 10);
        if (end == rest.c_str() + colon + 1 || *end != '\0' || port <= 0 || port > 65535) {
            return make_error("camera address '" + address + "': port '" + rest.substr(colon + 1) +
                              "' is not in [1, 65535]");
        }
        auto t = connect_u3v_tcp(rest.substr(0, colon), static_cast<std::uint16_t>(port));
        if (!t) {
            return tl::unexpected(t.error());
        }
        return upcast(U3vCamera::open(std::move(*t)));
    }
    const std::size_t colon = address.find(':');
    if (colon == std::string::npos) {
        return make_error("camera address '" + address +
                          "': expected gige://HOST, u3v://SERIAL, aravis:DEVICE-ID, "
                          "u3v-tcp://HOST:PORT, u3v-mem:NAME, usb:SERIAL, usb:BUS-ADDR or "
                          "uvc:INDEX");
    }
    const std::string scheme = address.substr(0, colon);
    const std::string rest = address.substr(colon + 1);
    if (scheme == "usb") {
        auto t = open_usb_transport(rest);
        if (!t) {
            return tl::unexpected(t.error());
        }
        return upcast(U3vCamera::open(std::move(*t)));
    }
    if (scheme == "uvc") {
        char* end = nullptr;
        const long index = std::strtol(rest.c_str(), &end, 10);
        if (rest.empty() || *end != '\0' || index < 0 || index > 255) {
            return make_error("camera address '" + address + "': index '" + rest +
                              "' is not in [0, 255]");
        }
        return open_uvc_camera(static_cast<int>(index));
    }
    CameraOpener opener;
    {
        std::lock_guard<std::mutex> lock(registry_mutex());
        auto it = registry().find(scheme);
        if (it != registry().end()) {
            opener = it->second;
        }
    }
    if (!opener) {
        return make_error("camera address '" + address + "': unknown scheme '" + scheme +
                          "' (gige://, u3v://, aravis:, u3v-tcp://, u3v-mem:, usb:, uvc:)");
    }
    return opener(rest);
}

}  // namespace gonio::devices
