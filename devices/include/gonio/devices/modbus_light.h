#pragma once

// The light source's shutter behind a Modbus coil (function 1 / 5), e.g. a relay output of a drive
// or an I/O module on the same bus as the motors.

#include <memory>
#include <string>

#include "gonio/devices/camera.h"
#include "gonio/devices/modbus_bus.h"

namespace gonio::devices {

class ModbusLight : public Light {
  public:
    /// `coil` is the wire (PDU) address of the shutter coil; on = open.
    ModbusLight(std::shared_ptr<ModbusBus> bus, int unit, int coil, RequestPolicy policy = {});
    Expected<void> set_shutter_open(bool open) override;
    Expected<bool> shutter_open() override;

  private:
    std::shared_ptr<ModbusBus> bus_;
    int unit_;
    int coil_;
    RequestPolicy policy_;
};

/// Opens (or shares) the bus at `address` and returns the shutter on `unit`, coil `coil`.
Expected<std::unique_ptr<Light>> open_modbus_light(const std::string& address, int unit, int coil);

}  // namespace gonio::devices
