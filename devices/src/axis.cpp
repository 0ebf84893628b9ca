#include "gonio/devices/axis.h"

namespace gonio::devices {

const char* to_string(AxisState s) {
    switch (s) {
        case AxisState::kIdle:
            return "idle";
        case AxisState::kMoving:
            return "moving";
        case AxisState::kHoming:
            return "homing";
        case AxisState::kAlarm:
            return "alarm";
        case AxisState::kDisconnected:
            return "disconnected";
    }
    return "unknown";
}

}  // namespace gonio::devices
