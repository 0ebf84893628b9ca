#pragma once

// Opens a camera from an address string:
//   gige://HOST          a GigE Vision camera at HOST (name or IPv4), opened directly through
//                        Aravis without a discovery broadcast
//   u3v://SERIAL         a USB3 Vision camera with this serial number, through Aravis
//   aravis:DEVICE-ID     any camera by the id Aravis gives it (`gonio devices`, `arv-tool-0.8`)
//   uvc:INDEX            a UVC webcam via OpenCV (not radiometric)

#include <memory>
#include <string>

#include "gonio/devices/camera.h"

namespace gonio::devices {

Expected<std::unique_ptr<Camera>> open_camera(const std::string& address);

}  // namespace gonio::devices
