#include "gonio/devices/modbus_light.h"

namespace gonio::devices {

ModbusLight::ModbusLight(std::shared_ptr<ModbusBus> bus, int unit, int coil, RequestPolicy policy)
    : bus_(std::move(bus)), unit_(unit), coil_(coil), policy_(policy) {}

Expected<void> ModbusLight::set_shutter_open(bool open) {
    return bus_->write_coil(unit_, coil_, open, policy_, "shutter coil " + std::to_string(coil_));
}

Expected<bool> ModbusLight::shutter_open() {
    return bus_->read_coil(unit_, coil_, policy_, "shutter coil " + std::to_string(coil_));
}

Expected<std::unique_ptr<Light>> open_modbus_light(const std::string& address, int unit, int coil) {
    if (unit < 1 || unit > 247) {
        return make_error("shutter: unit " + std::to_string(unit) + " not in [1, 247]");
    }
    if (coil < 0 || coil > 65535) {
        return make_error("shutter: coil " + std::to_string(coil) + " not in [0, 65535]");
    }
    auto bus = ModbusBus::shared(address);
    if (!bus) {
        return make_error("shutter: " + bus.error().message);
    }
    return std::unique_ptr<Light>(std::make_unique<ModbusLight>(*bus, unit, coil));
}

}  // namespace gonio::devices
