// The names of the device states: see device_state.hpp.
#include "base/device_state.hpp"

namespace palp {

const char* to_string(DeviceState state) {
  switch (state) {
    case DeviceState::Present:
      return "present";
    case DeviceState::Absent:
      return "absent";
    case DeviceState::Fault:
      return "fault";
    case DeviceState::Unknown:
      break;
  }
  return "unknown";
}

}  // namespace palp
