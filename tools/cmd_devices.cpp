// gonio devices: the USB devices a gonioreflectometer uses (U3V cameras, USB-serial adapters).

#include <CLI/CLI.hpp>
#include <cstdio>

#include "command.h"
#include "gonio/devices/usb_devices.h"

GONIO_COMMAND(devices) {
    auto* cmd = app.add_subcommand(
        "devices", "list USB3 Vision cameras and USB-serial adapters, with permission problems");
    (void)cmd;
    return []() -> int {
        auto list = gonio::devices::list_usb_devices();
        if (!list) {
            std::fprintf(stderr, "gonio devices: %s\n", list.error().message.c_str());
            return 1;
        }
        if (list->empty()) {
            std::printf(
                "no USB3 Vision camera or USB-serial adapter found (no USB bus visible, "
                "or nothing plugged in); a simulated camera is served by "
                "`gonio camera serve`\n");
            return 0;
        }
        for (const auto& d : *list) {
            const char* kind =
                d.kind == gonio::devices::UsbDeviceKind::kU3vCamera ? "camera" : "serial";
            std::printf("%-6s usb:%d-%d  %s", kind, d.bus, d.address, d.description.c_str());
            if (!d.serial.empty()) {
                std::printf("  serial %s", d.serial.c_str());
            }
            std::printf("\n");
            if (!d.problem.empty()) {
                std::printf("       %s\n", d.problem.c_str());
            }
        }
        return 0;
    };
}
