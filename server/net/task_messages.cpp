// The training task on palp.v1: see task_messages.hpp.
#include "net/task_messages.hpp"

#include <exception>

#include "base/errors.hpp"
#include "net/protocol.hpp"
#include "wire/messages.hpp"

namespace palp::net {

namespace {

void set_vec(const Vec3d& v, v1::Vec3* out) {
  out->set_x(v.x);
  out->set_y(v.y);
  out->set_z(v.z);
}

}  // namespace

bool may_see_answers(const TaskState& view, bool controller) {
  return !(controller && view.running);
}

void fill_task_status(const TaskState& view, bool controller, v1::TaskStatus* out) {
  out->set_running(view.running);
  out->set_task(view.task);
  out->set_trial(static_cast<std::uint32_t>(view.trial));
  out->set_marks(static_cast<std::uint32_t>(view.marks));
  out->set_trials_scored(static_cast<std::uint32_t>(view.trials_scored));
  out->set_samples_dropped(view.samples_dropped);
  out->set_marks_dropped(view.marks_dropped);
  out->set_note(view.note);
  out->set_report(view.report);
  out->set_revision(view.revision);
  const bool answers = may_see_answers(view, controller);
  out->set_show_landmarks(answers);
  if (!answers) return;
  if (view.target_scene) set_vec(*view.target_scene, out->mutable_target());
  if (view.last_mark && view.last_mark_scene) {
    v1::TaskMarkScore* m = out->mutable_last_mark();
    m->set_t_s(view.last_mark->mark.t);
    set_vec(*view.last_mark_scene, m->mutable_point());
    m->set_distance_mm(view.last_mark->distance_mm);
    m->set_in_target(view.last_mark->in_target);
    m->set_where(view.last_mark->where);
  }
}

void fill_landmarks(const TaskSession& task, v1::LandmarkSet* out) {
  out->set_source(task.landmarks_source());
  for (const WireLandmark& l : task.landmarks_for_clients()) {
    v1::Landmark* m = out->add_landmarks();
    m->set_name(l.name);
    m->set_kind(l.kind);
    set_vec(l.point, m->mutable_point());
  }
}

std::vector<Bytes> task_frames(const TaskSession& task, bool controller, bool& landmarks_sent) {
  std::vector<Bytes> out;
  if (!landmarks_sent && task.has_landmarks() && may_see_answers(task.view(), controller)) {
    v1::ServerMessage m;
    fill_landmarks(task, m.mutable_landmarks());
    out.push_back(frame_of(m));
    landmarks_sent = true;
  }
  v1::ServerMessage m;
  fill_task_status(task.view(), controller, m.mutable_task());
  out.push_back(frame_of(m));
  return out;
}

bool is_task_command(const v1::Command& c) {
  return c.has_task_start() || c.has_task_mark() || c.has_task_next_trial() || c.has_task_stop();
}

training::TaskSpec task_spec_of(const v1::TaskStart& t) {
  training::TaskSpec spec;
  const auto kind = training::parse_task_kind(t.kind());
  if (!kind) throw UsageError("unknown task '" + t.kind() + "' (ptcd, lumbar, femoral)");
  spec.kind = *kind;
  if (!t.side().empty()) {
    const auto side = anatomy::parse_side(t.side());
    if (!side) throw UsageError("task side must be right or left, got '" + t.side() + "'");
    spec.side = *side;
  }
  if (t.space() != 0) spec.space = static_cast<int>(t.space());
  if (!t.interspace().empty()) spec.interspace = t.interspace();
  return spec;
}

std::string apply_task_command(TaskSession* task, const v1::Command& c) {
  if (!task) return "this palpd runs no training tasks";
  try {
    if (c.has_task_start()) return task->start(task_spec_of(c.task_start()));
    if (c.has_task_mark()) return task->mark();
    if (c.has_task_next_trial()) return task->next_trial();
    if (c.has_task_stop()) return task->stop();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "not a task command";
}

}  // namespace palp::net
