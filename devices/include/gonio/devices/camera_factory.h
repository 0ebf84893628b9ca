#pragma once

// Opens a camera from an address string:
//   gige://HOST          a GigE Vision camera at HOST (name or IPv4), opened directly through
//                        Aravis without a discovery broadcast
//   u3v://SERIAL         a USB3 Vision camera with this serial number, through Aravis
//   aravis:DEVICE-ID     any camera by the id Aravis gives it (`gonio devices`, `arv-tool-0.8`)
//   u3v-tcp://127.0.0.1:PORT  a USB3 Vision device served over TCP (the simulator in another
//                        process)
//   u3v-mem:NAME         an in-process device registered under NAME (the simulator registers it)
//   usb:SERIAL | usb:BUS-ADDR  a USB3 Vision camera on libusb through gonio's own U3V client
//   uvc:INDEX            a UVC webcam via OpenCV (not radiometric)

#include <functional>
#include <memory>
#include <string>

#include "gonio/devices/camera.h"

namespace gonio::devices {

Expected<std::unique_ptr<Camera>> open_camera(const std::string& address);

/// Opener of the part of an address after "SCHEME:".
using CameraOpener = std::function<Expected<std::unique_ptr<Camera>>(const std::string& rest)>;

/// Registers an extra scheme (e.g. "u3v-mem"); replaces an earlier registration of the same scheme.
/// Thread-safe.
void register_camera_scheme(const std::string& scheme, CameraOpener opener);

}  // namespace gonio::devices
