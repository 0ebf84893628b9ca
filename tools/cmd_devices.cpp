// gonio devices: the cameras Aravis can open (GigE Vision and USB3 Vision), and the USB devices a
// gonioreflectometer uses (USB3 Vision cameras, USB-serial adapters) with permission problems.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>

#include "command.h"
#include "gonio/devices/aravis_camera.h"
#include "gonio/devices/usb_devices.h"

GONIO_COMMAND(devices) {
    auto* cmd = app.add_subcommand("devices",
                                   "list GenICam cameras (through Aravis), USB3 Vision cameras and "
                                   "USB-serial adapters, with permission problems");
    (void)cmd;
    return []() -> int {
        int rc = 0;
        auto cams = gonio::devices::list_aravis_devices();
        if (!cams) {
            std::fprintf(stderr, "gonio devices: %s\n", cams.error().message.c_str());
            rc = 1;
        } else if (cams->empty()) {
            std::printf("no GenICam camera found by Aravis (GigE Vision discovery, USB3 Vision)\n");
        } else {
            for (const auto& c : *cams) {
                const std::string open =
                    c.protocol == "GigEVision" && !c.address.empty()  ? "gige://" + c.address
                    : c.protocol == "USB3Vision" && !c.serial.empty() ? "u3v://" + c.serial
                                                                      : "aravis:" + c.id;
                std::printf("camera %-10s %-28s %s %s, serial %s  (also aravis:%s)\n",
                            c.protocol.c_str(),
                            open.c_str(),
                            c.vendor.c_str(),
                            c.model.c_str(),
                            c.serial.c_str(),
                            c.id.c_str());
            }
        }
        auto list = gonio::devices::list_usb_devices();
        if (!list) {
            std::fprintf(stderr, "gonio devices: %s\n", list.error().message.c_str());
            return 1;
        }
        if (list->empty()) {
            std::printf(
                "no USB3 Vision camera or USB-serial adapter found on USB (no USB bus visible, "
                "or nothing plugged in); a simulated camera is served by "
                "`gonio camera serve`\n");
            return rc;
        }
        for (const auto& d : *list) {
            const char* kind =
                d.kind == gonio::devices::UsbDeviceKind::kU3vCamera ? "camera" : "serial";
            std::printf("%-6s usb:%d-%d  %s", kind, d.bus, d.address, d.description.c_str());
            if (!d.serial.empty()) {
                std::printf("  serial %s", d.serial.c_str());
                if (d.kind == gonio::devices::UsbDeviceKind::kU3vCamera) {
                    std::printf("  (u3v://%s)", d.serial.c_str());
                }
            }
            std::printf("\n");
            if (!d.problem.empty()) {
                std::printf("       %s\n", d.problem.c_str());
            }
        }
        return rc;
    };
}
