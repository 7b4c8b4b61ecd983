// The offline run's loop (offline_run.hpp), shared by palp run and palp task.
#include "cli/offline_run.hpp"

namespace palp::cli {

void DeviceFilter::apply(ForceRecord& record, const Vec3d& position, double first_dt) {
  if (!profile) return;
  SafetyInput in;
  in.force = record.force;
  in.torque = record.torque;
  in.prev_force = prev_force;
  in.position = position;
  in.prev_position = started ? prev_position : position;
  in.dt = started ? record.t - prev_t : first_dt;
  const SafetyOutput out = apply_device_limits(*profile, in);
  record.force = out.force;
  record.torque = out.torque;
  record.safety = out.status;
  prev_force = out.force;
  prev_position = position;
  prev_t = record.t;
  started = true;
}

std::uint32_t run_offline(const Model& model, State& state, const Trajectory& trajectory,
                          DeviceFilter& filter, const OfflineTick& each) {
  const double first_dt = trajectory.size() > 1 ? trajectory[1].t - trajectory[0].t : 0.001;
  std::uint32_t status_seen = 0;
  for (const TrajectorySample& row : trajectory) {
    // Row -> tick -> record (contact summary) -> device limits -> the caller.
    tick(model, state, row.pose, row.t);  // the pulse's clock runs on the trajectory's time
    ForceRecord record = force_record(row.t, state);
    filter.apply(record, row.pose.position, first_dt);
    status_seen |= state.status;
    each(row, state, record);
  }
  return status_seen;
}

}  // namespace palp::cli
