// Opens a camera from its address string.

#include "gonio/devices/camera_factory.h"

#include <cstdlib>

#include "gonio/devices/aravis_camera.h"
#include "gonio/devices/uvc_camera.h"

namespace gonio::devices {

namespace {

template <class T>
Expected<std::unique_ptr<Camera>> upcast(Expected<std::unique_ptr<T>> c) {
    if (!c) {
        return tl::unexpected(c.error());
    }
    return std::unique_ptr<Camera>(std::move(*c));
}

}  // namespace

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
    const std::size_t colon = address.find(':');
    if (colon == std::string::npos) {
        return make_error("camera address '" + address +
                          "': expected gige://HOST, u3v://SERIAL, aravis:DEVICE-ID or "
                          "uvc:INDEX");
    }
    const std::string scheme = address.substr(0, colon);
    const std::string rest = address.substr(colon + 1);
    if (scheme == "uvc") {
        char* end = nullptr;
        const long index = std::strtol(rest.c_str(), &end, 10);
        if (rest.empty() || *end != '\0' || index < 0 || index > 255) {
            return make_error("camera address '" + address + "': index '" + rest +
                              "' is not in [0, 255]");
        }
        return open_uvc_camera(static_cast<int>(index));
    }
    return make_error("camera address '" + address + "': unknown scheme '" + scheme +
                      "' (gige://, u3v://, aravis:, uvc:)");
}

}  // namespace gonio::devices
