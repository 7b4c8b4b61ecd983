// The offline force-model run over a trajectory, one tick per row, deterministically: palp run
// writes its rows to a force CSV, palp task turns them into a trial's samples. One loop, so both
// see the same forces.
//   trajectory row (t, pose) -> tick (force model) -> force_record -> [device profile filters]
//   -> each(row, state, record)
#pragma once

#include <cstdint>
#include <functional>

#include "model/force_model.hpp"
#include "safety/safety.hpp"
#include "scene/trajectory.hpp"

namespace palp::cli {

// Device limits between ticks: the previous output and device position (spec: after the model).
struct DeviceFilter {
  const DeviceProfile* profile = nullptr;  // none: the model's own output
  Vec3d prev_force{};
  Vec3d prev_position{};
  double prev_t = 0.0;
  bool started = false;

  // Filters `record` in place; dt from the trajectory's times (the first tick: `first_dt`).
  void apply(ForceRecord& record, const Vec3d& position, double first_dt);
};

using OfflineTick =
    std::function<void(const TrajectorySample& row, const State& state, const ForceRecord& record)>;

// Ticks `model` once per row of `trajectory`, in order (the pulse's clock on the rows' t), and
// hands each tick's state and filtered record to `each`. Returns the TickStatus bits seen.
std::uint32_t run_offline(const Model& model, State& state, const Trajectory& trajectory,
                          DeviceFilter& filter, const OfflineTick& each);

}  // namespace palp::cli
