// palpd's answer to Commands (net::ControlTarget): tool and parameter changes swapped into the
// loop, the heart rate (SetParameter pulse_bpm) handed to the loop's atomic, pause, re-centre,
// recordings started and stopped (named files in --record-dir), and the remote device's poses.
// Commands come from the network thread; nothing here runs in the tick.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "devices/device.hpp"
#include "loop/haptic_loop.hpp"
#include "model/field_sampler.hpp"
#include "model/force_model.hpp"
#include "net/control_target.hpp"
#include "rt/recording.hpp"

namespace palp::app {

// The parameters as NAME=VALUE, as --param takes them (a recording's metadata keeps them).
std::vector<std::string> param_assignments(const ForceParams& p);

class PalpdControl final : public net::ControlTarget {
 public:
  PalpdControl(rt::HapticLoop& loop, std::shared_ptr<const FieldSampler> fields, rt::Device& device,
               rt::RecordingMetadata metadata, std::string record_dir);

  // A recording holds one tool and one parameter set (in its metadata), which is what lets a
  // replay reproduce every force; so they cannot change while one runs.
  static constexpr const char* kLockedWhileRecording =
      "stop the recording first: tool and parameters are fixed while recording, so that its "
      "replay reproduces every force";

  std::string set_tool(const std::string& name) override;
  std::string set_parameter(const std::string& name, double value) override;
  std::string set_paused(bool paused) override;
  std::string recentre() override;
  // A plain file name in --record-dir.
  std::string start_recording(const std::string& name, const std::string& requested_by) override;
  // Any path (palpd's own --record).
  std::string start(const std::filesystem::path& path, const std::string& requested_by);
  std::string stop_recording() override;
  bool recording() const override;
  std::uint64_t record_lost() const override { return loop_.stats().record_dropped; }
  bool set_device_pose(const Pose& pose, std::int64_t received_ns) override;
  std::uint64_t recorded() const;
  // The training task (palpd_task.hpp), set before the server starts; null: none.
  void set_task(net::TaskSession* task) { task_ = task; }
  net::TaskSession* task() override { return task_; }
  // A training mark at tick `seq` (deadline `t_ns`): kept with the recording that runs, written
  // beside it when it stops (rt::marks_path_for: NAME.marks.csv).
  void note_mark(std::uint64_t seq, std::int64_t t_ns);

 private:
  rt::HapticLoop& loop_;
  std::shared_ptr<const FieldSampler> fields_;
  rt::RemoteDevice* remote_;
  rt::RecordingMetadata metadata_;
  std::string record_dir_;
  mutable std::mutex mutex_;
  std::unique_ptr<rt::Recorder> recorder_;
  std::vector<std::pair<std::uint64_t, std::int64_t>> marks_;  // seq, t_ns; with recorder_
  net::TaskSession* task_ = nullptr;
};

}  // namespace palp::app
