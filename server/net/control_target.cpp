// Command dispatch: see control_target.hpp.
#include "net/control_target.hpp"

#include <exception>

#include "net/task_messages.hpp"

namespace palp::net {

std::string apply_command(ControlTarget* target, const v1::Command& c,
                          const std::string& requested_by, bool& scene_changed) {
  std::string failure;
  scene_changed = false;
  if (!target) {
    failure = "this server takes no commands";
  } else
    try {
      switch (c.kind_case()) {
        case v1::Command::kSetTool:
          failure = target->set_tool(c.set_tool().tool());
          scene_changed = failure.empty();
          break;
        case v1::Command::kSetParameter:
          failure = target->set_parameter(c.set_parameter().name(), c.set_parameter().value());
          scene_changed = failure.empty();
          break;
        case v1::Command::kPause:
          failure = target->set_paused(c.pause().paused());
          break;
        case v1::Command::kRecentre:
          failure = target->recentre();
          break;
        case v1::Command::kStartRecording:
          failure = target->start_recording(c.start_recording().name(), requested_by);
          break;
        case v1::Command::kStopRecording:
          failure = target->stop_recording();
          break;
        case v1::Command::kTaskStart:
        case v1::Command::kTaskMark:
        case v1::Command::kTaskNextTrial:
        case v1::Command::kTaskStop:
          failure = apply_task_command(target->task(), c);
          break;
        case v1::Command::KIND_NOT_SET:
          failure = "empty command";
          break;
      }
    } catch (const std::exception& e) {
      failure = e.what();
      scene_changed = false;
    }
  return failure;
}

}  // namespace palp::net
