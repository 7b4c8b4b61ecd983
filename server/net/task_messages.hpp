// The training task on palp.v1 (palpd's side): TaskStatus as one client may see it, the
// landmarks for the instructor's view, and the task Commands dispatched to the TaskSession.
#pragma once

#include <string>
#include <vector>

#include "net/client_queue.hpp"
#include "net/task_session.hpp"
#include "palp.pb.h"

namespace palp::net {

// Whether a client may see the landmarks, the target and the scores now: observers (the
// instructor) always; the controller (the trainee) never while a task runs.
bool may_see_answers(const TaskState& view, bool controller);

// The status for an observer or the controller.
void fill_task_status(const TaskState& view, bool controller, v1::TaskStatus* out);
// The landmarks as points in the scene frame, named.
void fill_landmarks(const TaskSession& task, v1::LandmarkSet* out);

// What one client is sent when it joins or the task changed: its TaskStatus and, the first time
// it may see them (`landmarks_sent` false, set here), the LandmarkSet before it.
std::vector<Bytes> task_frames(const TaskSession& task, bool controller, bool& landmarks_sent);

// Whether `command` is one of the task Commands; and runs it ("" or why not).
bool is_task_command(const v1::Command& command);
std::string apply_task_command(TaskSession* task, const v1::Command& command);

// TaskStart's fields as a TaskSpec (UsageError for an unknown kind or side).
training::TaskSpec task_spec_of(const v1::TaskStart& start);

}  // namespace palp::net
