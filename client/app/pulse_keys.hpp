// The controller's pulse keys (key_bindings.hpp): `,` and `.` step the arteries' heart rate down
// and up by kPulseStepBpm within [0, 240], `B` turns the pulse off and back on at the rate it had.
// Pure: the frame loop sends what pulse_request returns (StreamClient::set_pulse_bpm).
#pragma once

#include <optional>

namespace palp::view {

inline constexpr double kPulseStepBpm = 6.0;
inline constexpr double kMaxPulseBpm = 240.0;   // palpd's bound (SetParameter pulse_bpm)
inline constexpr double kRestingPulseBpm = 72;  // B's rate when the pulse was never on

// Set by the keys, taken (and cleared) by the frame loop.
struct PulseKeys {
  int steps = 0;        // , -1 and . +1, summed
  bool toggle = false;  // B
};

// The rate to ask palpd for, from the rate now (`now_bpm`: the frames', or SceneInfo's) and the
// keys; nullopt when nothing changes. `last_on_bpm` keeps the last rate above 0, for B.
std::optional<double> pulse_request(double now_bpm, const PulseKeys& keys, double& last_on_bpm);

}  // namespace palp::view
