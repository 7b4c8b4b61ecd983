// palp tune: per scene, tool and loop rate, the cheapest model configuration whose forces a hand
// cannot tell from the most accurate one, with the tick well inside the loop period.
//
// Data flow: scene maps (d_surf, d_bone) -> one FieldSampler per (gradient scheme, storage) ->
// candidates (sampler x contact-point count of the tool's footprint) -> the palpation
// trajectories (press, slides across the ribs at two speeds, a slide at constant depth), ticked
// at the loop rate -> per candidate: force error against the reference, the largest per-tick
// step beyond the reference's, tick time (median of repeats), memory -> judged against the
// tolerance and the time budget -> the cheapest accepted candidate.
//
// The reference is the most accurate configuration palp offers for the tool named: the
// precomputed (continuous) gradient, float32 maps, the tool's own contact points (finger:37 is
// the densest palp has; naming finger:7 makes 7 points the most a lab wants).
//
// Tolerance (docs/tuning.md), judged tick by tick: the force just-noticeable difference is
// ~7-10 % of the force (Jones 1989; Pang, Tan & Durlach 1991), and below ~0.5 N the hand's
// absolute threshold of a few tens of mN takes over. So at each tick a candidate's error
// |F - F_ref| may be max(abs_n, rel x |F_ref| at that tick); at most beyond_share of the ticks
// may exceed that, none by more than max_factor times; its per-tick step may exceed the
// reference's by at most that tick's tolerance.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "base/errors.hpp"
#include "base/volume.hpp"
#include "model/field_sampler.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"
#include "scene/trajectory.hpp"

namespace palp::tune {

struct Tolerance {
  double rel = 0.07;           // of the reference's force at each tick
  double abs_n = 0.035;        // N, the floor at each tick (light or no contact)
  double beyond_share = 0.01;  // share of the ticks that may exceed their tolerance
  double max_factor = 3.0;     // no tick's error beyond this many of its tolerances
  double tick_budget = 0.25;   // tick p99 at most this share of the loop period
  double time_tie = 0.10;      // ticks within this share of the fastest count as equally fast
};

// The force error allowed at a tick where the reference's force is `reference_n` (its norm):
// max(abs_n, rel x reference_n).
double allowed_n(const Tolerance& tol, double reference_n);

struct Candidate {
  std::string tool;       // canonical tool name, e.g. "finger:19"
  SamplerConfig sampler;  // gradient scheme and storage
};

struct Measured {
  double rms_error_n = 0.0;          // RMS over ticks of |F - F_ref|
  double max_error_n = 0.0;          // largest |F - F_ref|
  double lateral_rms_error_n = 0.0;  // RMS of the friction (tangential) part's error
  double step_excess_n = 0.0;        // max over ticks of |dF| - |dF_ref| (0 when never larger)
  // Judged per tick against allowed_n(|F_ref| at that tick):
  double beyond_share = 0.0;     // share of the ticks whose error exceeds their tolerance
  double worst_ratio = 0.0;      // the largest error / tolerance over the ticks
  double worst_error_n = 0.0;    // that tick's error,
  double worst_allowed_n = 0.0;  // its tolerance
  double worst_force_n = 0.0;    // and the reference's force there
  double step_ratio = 0.0;       // the largest (|dF| - |dF_ref|) / tolerance over the ticks
  double tick_p50_us = 0.0;      // median over repeats of each repeat's median tick
  double tick_p99_us = 0.0;      // median over repeats of each repeat's p99 tick
  std::size_t map_bytes = 0;     // the sampler's maps (and gradients, bone-beneath map)
};

struct Judged {
  Candidate candidate;
  Measured measured;
  bool reference = false;
  bool accepted = false;
  bool chosen = false;
  std::string reason;  // why rejected, or "accepted"
};

struct Outcome {
  std::vector<Judged> results;  // the reference first
  std::size_t chosen = 0;       // index into results (the reference when nothing cheaper passes)
  double reference_rms_force_n = 0.0;
  double light_share = 0.0;  // share of the ticks where the reference's force < abs_n / rel
  double period_us = 0.0;
  std::size_t ticks = 0;                  // ticks per candidate and repeat
  std::vector<std::string> trajectories;  // names of the trajectories used
};

// The pure decision: marks accepted / rejected (with the reason) and the chosen one, the
// cheapest accepted: among those whose tick p50 is within time_tie of the fastest accepted, the
// least memory, then the smallest force error, then order. results[0] is the reference; it is
// judged on time only (its errors are zero by definition). Returns the chosen index; when
// nothing passes (not even the reference's time) the reference is returned, marked not accepted.
std::size_t judge(std::vector<Judged>& results, const Tolerance& tol, double period_us);

// The force figures of a candidate's forces `f` against the reference's `ref` (one per tick,
// paths back to back; `normal`: the reference's skin normal at each tick, for the friction
// part), each tick judged against allowed_n(tol, |ref[t]|). Timings and memory are left 0.
Measured compare_forces(const std::vector<Vec3d>& f, const std::vector<Vec3d>& ref,
                        const std::vector<Vec3d>& normal, const Tolerance& tol);

// The contact-point counts palp offers for the footprint of `tool`, at most as dense as it
// (finger, twofinger: 37, 19, 7, 1 per pad up to the given count; probe: the grid as given and
// halved along each axis, down to 1x1), densest first. The first (the given tool) is the
// reference's: the tool a lab names is the most accurate it wants.
std::vector<std::string> footprint_tools(const Tool& tool);

struct Setup {
  std::string tool;  // any tool of the footprint (e.g. "finger:7")
  double rate_hz = 1000.0;
  ForceParams params;  // the model and its parameters for the tool's kind
  int repeats = 5;     // timing repeats (medians reported)
  Tolerance tolerance;
  double budget_s = 0.0;  // > 0: tune throws OverBudget once this much time has passed
};

// The time budget ran out before every candidate was measured (checked after each sampler is
// built and after each candidate: the overshoot is at most one of those steps).
class OverBudget : public Error {
 public:
  using Error::Error;
};

struct NamedTrajectory {
  std::string name;
  Trajectory path;
};

// The trajectories a hand uses on this scene at `rate_hz`: a press and hold, a slide at constant
// depth at several speeds, and (where the scene has a body axis) slides across the ribs at 20 and
// 100 mm/s. Those that do not fit the scene are left out (none left: InputError).
std::vector<NamedTrajectory> palpation_trajectories(const FieldSampler& fields, const Tool& tool,
                                                    double rate_hz);

// Progress: a line per candidate measured.
using Progress = void (*)(const Judged& judged, std::size_t index, std::size_t count);

// Measures every candidate on the maps (copied into each sampler) and judges them.
Outcome tune(const DistanceMap& surf, const DistanceMap& bone, const Setup& setup,
             Progress progress = nullptr);

// The machine class a tuning's timings hold for: core count and CPU model ("2 cores, AMD EPYC
// ..."), read from /proc/cpuinfo ("unknown CPU" elsewhere).
std::string machine_class();

}  // namespace palp::tune
