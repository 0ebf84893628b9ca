// Listing the USB devices a gonioreflectometer uses, with libusb.

#include "gonio/devices/usb_devices.h"

#include <libusb.h>

#include <cstdio>

namespace gonio::devices {

namespace {

std::string vidpid(std::uint16_t v, std::uint16_t p) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%04x:%04x", v, p);
    return buf;
}

bool has_u3v_control(libusb_device* dev) {
    libusb_config_descriptor* cfg = nullptr;
    if (libusb_get_active_config_descriptor(dev, &cfg) != 0 &&
        libusb_get_config_descriptor(dev, 0, &cfg) != 0) {
        return false;
    }
    bool found = false;
    for (int i = 0; i < cfg->bNumInterfaces && !found; ++i) {
        const libusb_interface& itf = cfg->interface[i];
        for (int a = 0; a < itf.num_altsetting; ++a) {
            const libusb_interface_descriptor& d = itf.altsetting[a];
            if (d.bInterfaceClass == kU3vInterfaceClass &&
                d.bInterfaceSubClass == kU3vInterfaceSubclass &&
                d.bInterfaceProtocol == kU3vProtocolControl) {
                found = true;
            }
        }
    }
    libusb_free_config_descriptor(cfg);
    return found;
}

std::string string_descriptor(libusb_device_handle* h, std::uint8_t index) {
    if (index == 0) {
        return {};
    }
    unsigned char buf[256];
    const int n = libusb_get_string_descriptor_ascii(h, index, buf, sizeof buf);
    return n > 0 ? std::string(reinterpret_cast<char*>(buf), static_cast<std::size_t>(n))
                 : std::string();
}

}  // namespace

std::string usb_serial_chip(std::uint16_t vendor_id, std::uint16_t product_id) {
    struct Chip {
        std::uint16_t vid, pid;
        const char* name;
    };
    static const Chip kChips[] = {
        {0x0403, 0x6001, "FTDI FT232R/FT245R"},
        {0x0403, 0x6010, "FTDI FT2232"},
        {0x0403, 0x6011, "FTDI FT4232"},
        {0x0403, 0x6014, "FTDI FT232H"},
        {0x0403, 0x6015, "FTDI FT-X series"},
        {0x10c4, 0xea60, "Silicon Labs CP210x"},
        {0x10c4, 0xea70, "Silicon Labs CP2105"},
        {0x1a86, 0x7523, "WCH CH340"},
        {0x1a86, 0x5523, "WCH CH341"},
        {0x1a86, 0x55d4, "WCH CH9102"},
        {0x067b, 0x2303, "Prolific PL2303"},
    };
    for (const Chip& c : kChips) {
        if (c.vid == vendor_id && c.pid == product_id) {
            return c.name;
        }
    }
    return {};
}

std::string udev_rule_hint(std::uint16_t vendor_id) {
    char buf[512];
    std::snprintf(buf,
                  sizeof buf,
                  "permission denied: run `sudo share/gonio/gonio-device-access grant USER` of the "
                  "install (USB3 Vision cameras and the groups plugdev and dialout; "
                  "docs/install.md), or for another device add a udev rule such as "
                  "SUBSYSTEM==\"usb\", ATTR{idVendor}==\"%04x\", MODE=\"0660\", GROUP=\"plugdev\" "
                  "to /etc/udev/rules.d/99-gonio.rules, run `udevadm control --reload` and "
                  "replug (and be in the plugdev group)",
                  vendor_id);
    return buf;
}

Expected<std::vector<UsbDeviceEntry>> list_usb_devices() {
    libusb_context* ctx = nullptr;
    if (const int rc = libusb_init(&ctx); rc != 0) {
        return make_error(std::string("libusb_init: ") + libusb_error_name(rc));
    }
    libusb_device** list = nullptr;
    const ssize_t n = libusb_get_device_list(ctx, &list);
    std::vector<UsbDeviceEntry> out;
    for (ssize_t i = 0; i < n; ++i) {
        libusb_device* dev = list[i];
        libusb_device_descriptor desc{};
        if (libusb_get_device_descriptor(dev, &desc) != 0) {
            continue;
        }
        UsbDeviceEntry e;
        e.vendor_id = desc.idVendor;
        e.product_id = desc.idProduct;
        e.bus = libusb_get_bus_number(dev);
        e.address = libusb_get_device_address(dev);
        const std::string chip = usb_serial_chip(desc.idVendor, desc.idProduct);
        if (!chip.empty()) {
            e.kind = UsbDeviceKind::kUsbSerial;
            e.description = chip + " USB-serial (" + vidpid(desc.idVendor, desc.idProduct) + ")";
        } else if (has_u3v_control(dev)) {
            e.kind = UsbDeviceKind::kU3vCamera;
            e.description = "USB3 Vision camera (" + vidpid(desc.idVendor, desc.idProduct) + ")";
        } else {
            continue;
        }
        libusb_device_handle* h = nullptr;
        const int rc = libusb_open(dev, &h);
        if (rc == LIBUSB_ERROR_ACCESS) {
            e.problem = udev_rule_hint(desc.idVendor);
        } else if (rc != 0) {
            e.problem = std::string("cannot open: ") + libusb_error_name(rc);
        } else {
            e.serial = string_descriptor(h, desc.iSerialNumber);
            const std::string product = string_descriptor(h, desc.iProduct);
            const std::string maker = string_descriptor(h, desc.iManufacturer);
            if (!product.empty()) {
                e.description += ": " + maker + (maker.empty() ? "" : " ") + product;
            }
            libusb_close(h);
        }
        out.push_back(std::move(e));
    }
    if (n >= 0) {
        libusb_free_device_list(list, 1);
    }
    libusb_exit(ctx);
    return out;
}

}  // namespace gonio::devices
