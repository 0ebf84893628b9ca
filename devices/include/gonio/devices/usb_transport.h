#pragma once

// The libusb carrier of U3V bytes for hardware: finds the U3V control and streaming interfaces by
// class/subclass/protocol, claims them, and runs bulk transfers with timeouts.

#include <memory>
#include <string>

#include "gonio/devices/u3v_transport.h"

namespace gonio::devices {

/// Opens the U3V device selected by `selector`: a serial number ("usb:SERIAL") or "BUS-ADDR"
/// ("usb:2-7"). Errors say whether nothing matched or access was denied (with the udev hint).
Expected<std::unique_ptr<U3vTransport>> open_usb_transport(const std::string& selector);

}  // namespace gonio::devices
