#include "gonio/devices/filter_wheel.h"

#include "gonio/devices/modbus_light.h"

namespace gonio::devices {

ModbusFilterWheel::ModbusFilterWheel(std::array<std::unique_ptr<Light>, 3> coils)
    : coils_(std::move(coils)) {}

Expected<void> ModbusFilterWheel::set_filter(int channel) {
    if (channel < 0 || channel > 2) {
        return make_error("filter wheel: channel " + std::to_string(channel) +
                          " not in [0, 2] (red, green, blue)");
    }
    // The other filters out first, then the requested one in.
    for (int c = 0; c < 3; ++c) {
        if (c == channel) {
            continue;
        }
        if (auto r = coils_[c]->set_shutter_open(false); !r) {
            return make_error("filter wheel: channel " + std::to_string(c) + ": " +
                              r.error().message);
        }
    }
    if (auto r = coils_[channel]->set_shutter_open(true); !r) {
        return make_error("filter wheel: channel " + std::to_string(channel) + ": " +
                          r.error().message);
    }
    return {};
}

Expected<std::unique_ptr<FilterWheel>> open_modbus_filter_wheel(
    const std::string& address, const std::array<FilterCoil, 3>& coils) {
    std::array<std::unique_ptr<Light>, 3> lights;
    for (int c = 0; c < 3; ++c) {
        auto l = open_modbus_light(address, coils[c].unit, coils[c].coil);
        if (!l) {
            return make_error("filter wheel: channel " + std::to_string(c) + ": " +
                              l.error().message);
        }
        lights[c] = std::move(*l);
    }
    return std::unique_ptr<FilterWheel>(std::make_unique<ModbusFilterWheel>(std::move(lights)));
}

}  // namespace gonio::devices
