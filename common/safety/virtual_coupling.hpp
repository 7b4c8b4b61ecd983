// A virtual coupling between the force model and the device (Colgate, Stanley & Brown 1995): the
// model is evaluated at a virtual tool, not at the device, and the device feels only a
// spring-damper to that tool. Whatever the model's stiffness (the skin law reaches 193 N/mm, the
// bone law 30 N/mm), the device sees at most the coupling's stiffness K_c, chosen at or below
// what the device renders stably, with a damping B_c = 2 K_c T at the loop period T.
//
// This is not passive by itself. Colgate & Schenkel (1997) show a sampled spring K with a
// backward-difference damper B is passive if the device's own damping b > K T / 2 + |B|: virtual
// damping raises the physical damping needed, it does not stand in for it. For this coupling
// that is b > 2.5 K_c T (passive_device_damping()), e.g. 7.5 N s/m for the Falcon class at
// 1 kHz, more than the devices the studies assume have (0.1-1 N s/m) at any rate palp offers
// (docs/stability.md has the table). Stability in closed loop rests on the operator's hand (its
// mass and damping on the handle), which the closed-loop studies model, and on the passivity
// controller behind the coupling (passivity.hpp), which bounds what the port can give out.
//
// The virtual tool is massless and moved implicitly once per tick (one Newton step of its
// equilibrium between the model force and the coupling, the model linearised with the
// stiffness estimate K):
//
//   Δ     = (F_e + K_c (x_d - x_v) + B_c v_d) / (K + K_c + B_c / T)
//   x_v  += Δ
//   F_dev = K_c (x_v - x_d) + B_c (Δ / T - v_d)          (= F_e - K Δ)
//
// F_e the model's force at the virtual tool, x_d and v_d the device's position and velocity (the
// velocity from positions, one tick apart). K is the larger of the model's own slope
// (State::stiffness) and the secant of the model's force along the tool's last step, which
// decays over 20 ms: a step in the model's force (a law switching on) counts as a large
// stiffness, so the tool stops at the step and the device feels the coupling's spring there
// instead of the step. Out of contact F_e = 0 and K = 0, so F_dev = 0 exactly: free motion is
// free. An over-estimate of K only slows the tool; the update is stable for any K at least
// half the model's true slope. The coupling never pulls: where F_e - K Δ would point against F_e
// (or, out of contact, against the model's last force; the tool leaving the surface), the tool
// takes the free step (F_e and K taken as 0), which writes exactly 0.
//
// Pure: the state is a value the caller keeps; reset after a fault (the tool restarts at the
// device).
#pragma once

#include "base/vec.hpp"
#include "safety/safety.hpp"

namespace palp {

struct CouplingGains {
  double stiffness_N_per_mm = 0.0;  // K_c
  double damping_N_s_per_mm = 0.0;  // B_c
};

// The profile's transport delay (s), taken in [0, kMaxTransportDelayS] (non-finite: 0).
inline constexpr double kMaxTransportDelayS = 0.02;
double transport_delay(const DeviceProfile& limits);

// The coupling for `limits` at tick `dt` (s): K_c = the profile's stable stiffness, B_c =
// 2 K_c (dt + 2 t_d) with t_d the profile's transport delay, at most the profile's damping; where
// that cap binds, K_c is lowered to B_max / (2 (dt + 2 t_d)) so the ratio still holds. Both
// factors were chosen by measurement with a hand on the device: with no delay, study_stability
// ran 0.75, 1, 2 and 4 times K_c dt and 2 left the least injected energy; a delay lags the spring
// by t_d more (a spring lagging by τ acts as a damping down to -K τ) and delays the damper too,
// and study_delay_release cycled with 2 K_c (dt + t_d) where 2 K_c (dt + 2 t_d) held
// (docs/stability.md, "Delay and release").
CouplingGains coupling_gains(const DeviceProfile& limits, double dt);

// The device damping (N·s/mm) Colgate & Schenkel's sufficient condition asks for the coupling
// `gains` rendered every `dt` s to be passive with no hand on the device: K_c T / 2 + |B_c|.
// With `delay_ticks` d ticks between the sample and the force's application, the spring's lag
// grows from T / 2 to (d + 1/2) T and the same argument (a spring lagging by τ acts at most as a
// damping of -K τ) gives K_c (d + 1/2) T + |B_c|: an estimate, not their theorem.
double passive_device_damping(const CouplingGains& gains, double dt, int delay_ticks = 0);

struct CouplingState {
  Vec3d tool{};           // virtual tool position (device frame, mm)
  Vec3d tool_prev{};      // where the model was evaluated the tick before
  Vec3d force_prev{};     // the model's force there
  Vec3d device_prev{};    // device position at the previous tick
  Vec3d out_direction{};  // the model's last non-zero force (no-pull rule)
  double secant_N_per_mm = 0.0;
  bool have = false;        // tool and device_prev are set
  bool have_model = false;  // tool_prev and force_prev are set
};

// Where the model is to be evaluated this tick (device frame): the virtual tool, or the device
// itself before the first coupled tick.
Vec3d coupled_tool(const CouplingState& state, const Vec3d& device_position);

struct CouplingOutput {
  Vec3d force{};  // what the device is to be written (N, device frame)
};

// One tick: `model_force` (N) and `model_stiffness` (N/mm) the model's at coupled_tool(),
// `device_position` (mm), `dt` (s, taken in (0, kMaxFilterDt]).
CouplingOutput couple(CouplingState& state, const CouplingGains& gains, const Vec3d& model_force,
                      double model_stiffness, const Vec3d& device_position, double dt);

// The tool restarts at the device (after a fault, a model change, a pause).
void reset_coupling(CouplingState& state);

}  // namespace palp
