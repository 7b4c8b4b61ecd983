// What palpd's controller may ask for: the ControlTarget interface palpd implements, and the
// dispatch of a Command to it.
#pragma once

#include <string>

#include "loop/haptic_loop.hpp"
#include "palp.pb.h"

namespace palp::net {

class TaskSession;

// What Commands do; palpd wires it to the loop, the recorder and the remote device. Each
// returns "" on success or the reason for refusing. Called on the io thread.
class ControlTarget {
 public:
  virtual ~ControlTarget() = default;
  virtual std::string set_tool(const std::string& tool) = 0;
  virtual std::string set_parameter(const std::string& name, double value) = 0;
  virtual std::string set_paused(bool paused) = 0;
  virtual std::string recentre() = 0;
  // `requested_by`: who asked (the client, as the log names it), noted in the recording.
  virtual std::string start_recording(const std::string& name, const std::string& requested_by) = 0;
  virtual std::string stop_recording() = 0;
  virtual bool recording() const = 0;
  virtual std::uint64_t record_lost() const = 0;
  // false: there is no remote device to drive.
  virtual bool set_device_pose(const Pose& pose, std::int64_t received_ns) = 0;
  // The training task (task Commands, TaskStatus and the landmarks to clients); null: palpd
  // runs none. Used on the io thread only.
  virtual TaskSession* task() { return nullptr; }
};

// Runs `command` from the client `requested_by` on `target` (none: the server takes no
// commands). Returns "" or the reason it was refused (an exception's message included);
// `scene_changed` tells whether SceneInfo must be sent again (a tool or parameter changed).
std::string apply_command(ControlTarget* target, const v1::Command& command,
                          const std::string& requested_by, bool& scene_changed);

}  // namespace palp::net
