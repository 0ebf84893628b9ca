#pragma once

// The commands that need the device, camera or image libraries (Aravis, libmodbus, libusb, OpenCV,
// OpenEXR). They live in the executable gonio-full, built beside gonio; gonio itself links only
// the BRDF, fitting and batch modules, so that fit, eval, convert and check start without loading
// those libraries, and runs gonio-full (execv, same arguments, same process) when one of these
// commands is asked for. The descriptions are the ones gonio-full gives its subcommands (a test
// compares both --help listings). Every summary in one style: lower case, a verb first, no full
// stop.

namespace gonio::tools {

struct FullCommand {
    const char* name;
    const char* description;
};

inline constexpr FullCommand kFullCommands[] = {
    {"acquire",
     "run a measurement campaign (no arguments: a default material on the embedded virtual rig)"},
    {"axis", "drive one Modbus axis by hand, or serve simulated ones"},
    {"camera",
     "inspect a camera, capture an OpenEXR frame, or serve the simulated GigE Vision camera"},
    {"devices",
     "list GenICam cameras (through Aravis), USB3 Vision cameras and USB-serial adapters, with "
     "permission problems"},
    {"export", "write a fitted model as a Mitsuba 3, pbrt-v4 or Blender material, or a MERL table"},
    {"plot",
     "draw polar in-plane slices, delta_phi slices and (with --fit) residual maps, as PNG files"},
    {"preview", "render a sphere under a directional light and a sky/ground environment (PNG)"},
    {"report",
     "write DIR/report.html for a point or image-mode campaign folder: the result (verdict, model, "
     "parameters), pictures, coverage, calibration, run history, raw descriptions"},
    {"sim", "serve the virtual rig (motor controllers and camera) until Ctrl-C"},
};

}  // namespace gonio::tools
