#pragma once

// A colour filter changer in front of a monochrome detector: one of three filters (red, green,
// blue; channel 0, 1, 2) in the beam at a time. The Modbus form drives one coil per filter (on =
// that filter in the beam), e.g. the relay outputs of an I/O module on the motors' bus; selecting
// a channel switches the other coils off before it switches its own on, so two filters are never
// requested together.

#include <array>
#include <memory>
#include <string>

#include "gonio/base/error.h"
#include "gonio/devices/camera.h"

namespace gonio::devices {

class FilterWheel {
  public:
    virtual ~FilterWheel() = default;
    /// Puts the filter of `channel` (0 = red, 1 = green, 2 = blue) into the beam. Errors: a
    /// channel outside [0, 2], or the device's own error.
    virtual Expected<void> set_filter(int channel) = 0;
};

/// Where one filter's coil is: unit and wire (PDU) coil address.
struct FilterCoil {
    int unit = 0;
    int coil = 0;
};

class ModbusFilterWheel : public FilterWheel {
  public:
    /// `coils[c]` switches the filter of channel c.
    explicit ModbusFilterWheel(std::array<std::unique_ptr<Light>, 3> coils);
    Expected<void> set_filter(int channel) override;

  private:
    std::array<std::unique_ptr<Light>, 3> coils_;
};

/// Opens (or shares) the bus at `address` and returns the filter changer with the given coils
/// (red, green, blue).
Expected<std::unique_ptr<FilterWheel>> open_modbus_filter_wheel(
    const std::string& address, const std::array<FilterCoil, 3>& coils);

}  // namespace gonio::devices
