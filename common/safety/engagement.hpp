// Force engagement: after start, a fault, a replug, a tool, parameter or scene change, an unpause
// or any reset of the model's state, the device gets no force until the force palp would send is
// small (below `threshold_N`, CHAI3D's 0.2 N), then the force is ramped in linearly over
// `ramp_s`. No reset ever hands the hand a full-force step.
//
// Pure: the state is a value the loop keeps; engage() maps (state, commanded force, dt) to the
// next state and the gain to apply.
//
//   reset (Engagement{}) ─► waiting: gain 0 while |F| >= threshold
//                           └─ |F| < threshold ─► ramping: gain += dt / ramp_s ─► engaged: gain 1
#pragma once

namespace palp {

struct EngageParams {
  double threshold_N = 0.2;  // engage only below this commanded force
  double ramp_s = 1.5;       // then from gain 0 to 1 in this long
};

struct Engagement {
  bool waiting = true;  // for the commanded force to be small
  double gain = 0.0;    // applied to the force: 0 while waiting, then up to 1
  bool engaged() const { return !waiting && gain >= 1.0; }
};

// One tick with `commanded_N` (the force magnitude palp would send) and `dt` seconds since the
// last tick (taken in [0, 0.01]).
Engagement engage(Engagement state, double commanded_N, double dt, const EngageParams& params);

// UsageError for a threshold outside (0, 5] N or a ramp outside [0, 10] s.
void validate(const EngageParams& params);

}  // namespace palp
