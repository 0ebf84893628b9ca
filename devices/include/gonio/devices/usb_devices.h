#pragma once

// USB discovery with libusb: U3V cameras (interface class 0xEF, subclass 0x05: protocol 0 =
// control, 1 = event, 2 = streaming) and USB-serial adapters used for RS-485 motor buses (FTDI,
// CP210x, CH340/CH9102, PL2303), with the reason when a device cannot be opened.

#include <cstdint>
#include <string>
#include <vector>

#include "gonio/base/error.h"

namespace gonio::devices {

inline constexpr std::uint8_t kU3vInterfaceClass = 0xEF;
inline constexpr std::uint8_t kU3vInterfaceSubclass = 0x05;
inline constexpr std::uint8_t kU3vProtocolControl = 0x00;
inline constexpr std::uint8_t kU3vProtocolEvent = 0x01;
inline constexpr std::uint8_t kU3vProtocolStream = 0x02;

enum class UsbDeviceKind {
    kU3vCamera,  ///< has a U3V control interface
    kUsbSerial,  ///< a known USB-serial bridge
};

struct UsbDeviceEntry {
    UsbDeviceKind kind = UsbDeviceKind::kU3vCamera;
    std::uint16_t vendor_id = 0;
    std::uint16_t product_id = 0;
    int bus = 0;
    int address = 0;
    std::string serial;       ///< empty when the device could not be opened
    std::string description;  ///< "FTDI FT232R", manufacturer/product strings...
    std::string problem;      ///< empty, or why it could not be opened (and the fix)
};

/// Describes a known USB-serial bridge by VID:PID, or empty.
std::string usb_serial_chip(std::uint16_t vendor_id, std::uint16_t product_id);

/// Lists the devices that matter. An empty list (no USB in a container) is not an error; a
/// libusb initialisation failure is.
Expected<std::vector<UsbDeviceEntry>> list_usb_devices();

/// The udev rule hint shown when permission is denied.
std::string udev_rule_hint(std::uint16_t vendor_id);

}  // namespace gonio::devices
