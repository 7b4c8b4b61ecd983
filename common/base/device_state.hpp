// A haptic device's state as palpd and every client name it: palp.v1's DeviceState, with the same
// numbers (proto/wire converts), the loop's snapshots (rt), a USB link's state (usb) and what
// palpview shows (view). Defined once here so each name is written once.
#pragma once

#include <cstdint>

namespace palp {

enum class DeviceState : std::uint8_t {
  Unknown = 0,  // not said (yet): a client before palpd's first Stats; palpd never reports it
  Present = 1,  // streaming
  Absent = 2,   // not plugged in, unplugged, or not yet found: zero force
  Fault = 3,    // plugged in but failing (permission, handshake, device fault bits): zero force
};

// "unknown", "present", "absent", "fault".
const char* to_string(DeviceState state);

}  // namespace palp
