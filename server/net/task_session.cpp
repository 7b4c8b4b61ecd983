// palpd's training task, live: see task_session.hpp.
#include "net/task_session.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <utility>

#include "base/errors.hpp"
#include "base/patient_frame.hpp"

namespace palp::net {

namespace {

std::string side_letter(anatomy::Side side) {
  return side == anatomy::Side::right ? "R" : "L";
}

}  // namespace

std::vector<WireLandmark> wire_landmarks(const anatomy::Landmarks& l, const Grid& grid) {
  std::vector<WireLandmark> out;
  const auto add = [&](std::string name, const char* kind, const Vec3d& lps) {
    out.push_back({std::move(name), kind, scene_of_world(grid, lps)});
  };
  for (const anatomy::IntercostalSpace& s : l.intercostal_spaces)
    if (s.skin_point && s.upper_rib)
      add("ICS " + side_letter(s.side) + std::to_string(*s.upper_rib) + "/" +
              std::to_string(*s.upper_rib + 1),
          "intercostal", *s.skin_point);
  for (const anatomy::Rib& r : l.ribs) {
    const std::string name =
        "rib " + side_letter(r.side) + (r.number ? std::to_string(*r.number) : "?");
    const std::size_t n = r.points.size(), shown = std::min<std::size_t>(n, 8);
    for (std::size_t i = 0; i < shown; ++i)
      add(name, "rib", r.points[shown > 1 ? i * (n - 1) / (shown - 1) : 0]);
  }
  for (const anatomy::Vertebra& v : l.vertebrae) {
    const std::string name = v.name.value_or("?");
    add(name, "vertebra", v.body_centre);
    if (v.spinous_tip) add(name + " spinous", "spinous", *v.spinous_tip);
  }
  for (const anatomy::IliacCrest& c : l.iliac_crests)
    if (c.top) add("iliac crest " + side_letter(c.side), "iliac", *c.top);
  for (const anatomy::LumbarInterspace& s : l.lumbar_interspaces)
    if (s.skin_point) add(s.name, "interspace", *s.skin_point);
  for (const anatomy::FemoralPulsePoint& f : l.femoral_pulse_points)
    if (f.skin_point) add("femoral " + side_letter(f.side), "femoral", *f.skin_point);
  if (out.size() > kMaxWireLandmarks)
    throw UsageError("landmarks: " + std::to_string(out.size()) + " points for the clients, " +
                     "more than " + std::to_string(kMaxWireLandmarks));
  return out;
}

TaskSession::TaskSession(TaskSetup setup) : setup_(std::move(setup)) {
  if (setup_.landmarks) wire_ = wire_landmarks(*setup_.landmarks, setup_.grid);
  if (!(setup_.sample_rate_hz > 0.0)) throw UsageError("task sample rate must be > 0");
  samples_.reserve(setup_.max_samples);
  marks_.reserve(setup_.max_marks);
  trials_.reserve(setup_.max_trials);
}

training::TrialSample TaskSession::sample_of(const rt::Snapshot& snap) const {
  training::TrialSample s;
  s.device_point = world_of_scene(setup_.grid, snap.tick.pose.position);
  Vec3d sum{};
  int n = 0;
  for (std::uint32_t i = 0; i < snap.contact_count && i < snap.contacts.size(); ++i) {
    if (!snap.contacts[i].in_contact) continue;
    sum += snap.contacts[i].p;  // the proxies lie on the skin
    ++n;
  }
  s.in_contact = n > 0;
  s.skin_point = n > 0 ? world_of_scene(setup_.grid, sum * (1.0 / n)) : s.device_point;
  s.normal_force = norm(snap.tick.force);
  return s;
}

void TaskSession::offer(const rt::Snapshot& snap) {
  latest_ = sample_of(snap);
  latest_t_ns_ = snap.tick.t_ns;
  latest_seq_ = snap.tick.seq;
  have_latest_ = true;
  const bool pressed = (snap.buttons & rt::kMarkButton) && !(last_buttons_ & rt::kMarkButton);
  last_buttons_ = snap.buttons;
  if (!view_.running) return;
  if (trial_t0_ns_ == 0) begin_trial(snap.tick.t_ns);
  if (snap.tick.t_ns >= next_sample_ns_) {
    const auto period = static_cast<std::int64_t>(1e9 / setup_.sample_rate_hz);
    next_sample_ns_ = std::max(next_sample_ns_ + period, snap.tick.t_ns + 1);
    if (samples_.size() < setup_.max_samples) {
      training::TrialSample s = latest_;
      s.t = static_cast<double>(snap.tick.t_ns - trial_t0_ns_) * 1e-9;
      samples_.push_back(s);  // within the reserved capacity: no allocation
    } else {
      ++view_.samples_dropped;  // counted; the status says so at the next change
    }
  }
  if (pressed) mark_now("button");
  while (next_replay_ < replay_ticks_.size() && replay_ticks_[next_replay_] <= snap.tick.seq) {
    ++next_replay_;
    mark_now("replay");
  }
}

void TaskSession::begin_trial(std::int64_t t_ns) {
  trial_t0_ns_ = t_ns;
  next_sample_ns_ = t_ns;
  if (session_started_ns_ == 0) session_started_ns_ = t_ns;
}

std::string TaskSession::start(const training::TaskSpec& spec) {
  if (view_.running) return "a task is running (" + view_.task + "): stop it first";
  if (!setup_.landmarks)
    return "palpd has no landmarks: start it with --landmarks FILE (palp landmarks writes one)";
  try {
    training::validate(spec);
    target_ = training::resolve_target(spec, *setup_.landmarks);
  } catch (const std::exception& e) {
    return e.what();
  }
  trials_.clear();
  samples_.clear();
  marks_.clear();
  const std::uint64_t revision = view_.revision;
  view_ = TaskState{};
  view_.revision = revision;
  view_.running = true;
  view_.task = training::describe(spec);
  view_.trial = 1;
  view_.target_scene = scene_of_world(setup_.grid, target_->point);
  for (const std::string& n : target_->notes) view_.note += (view_.note.empty() ? "" : "; ") + n;
  trial_t0_ns_ = session_started_ns_ = 0;
  if (have_latest_) begin_trial(latest_t_ns_);
  changed();
  return {};
}

std::string TaskSession::mark() {
  return mark_now("command");
}

std::string TaskSession::mark_now(const char* /*by*/) {
  if (!view_.running) return "no task is running (task start first)";
  if (!have_latest_ || trial_t0_ns_ == 0) return "no pose from the device yet";
  if (marks_.size() >= setup_.max_marks) {
    ++view_.marks_dropped;
    changed();
    return "at most " + std::to_string(setup_.max_marks) +
           " marks a trial: this one is counted, not scored (task next for a new trial)";
  }
  training::Mark m;
  m.t = std::max(0.0, static_cast<double>(latest_t_ns_ - trial_t0_ns_) * 1e-9);
  m.point = latest_.skin_point;
  marks_.push_back(m);
  view_.marks = marks_.size();
  if (setup_.on_mark) setup_.on_mark(latest_seq_, latest_t_ns_);
  score_last_mark();
  changed();
  return {};
}

void TaskSession::score_last_mark() {
  try {
    const training::TrialScore score =
        training::score_trial(*target_, *setup_.landmarks, samples_, marks_);
    if (score.marks.empty()) return;
    view_.last_mark = score.marks.back();
    view_.last_mark_scene = scene_of_world(setup_.grid, score.marks.back().mark.point);
  } catch (const std::exception& e) {
    view_.note = std::string("scoring: ") + e.what();
  }
}

void TaskSession::end_trial() {
  ScoredTrial trial;
  trial.number = view_.trial;
  trial.samples = samples_;
  trial.marks = marks_;
  try {
    trial.score = training::score_trial(*target_, *setup_.landmarks, samples_, marks_);
  } catch (const std::exception& e) {
    trial.error = e.what();
  }
  trials_.push_back(std::move(trial));
  view_.trials_scored = trials_.size();
  samples_.clear();
  marks_.clear();
  view_.marks = 0;
  trial_t0_ns_ = 0;
  if (have_latest_) begin_trial(latest_t_ns_);
}

std::string TaskSession::next_trial() {
  if (!view_.running) return "no task is running (task start first)";
  if (trials_.size() + 1 >= setup_.max_trials)
    return "at most " + std::to_string(setup_.max_trials) + " trials a session: task stop";
  end_trial();
  ++view_.trial;
  changed();
  return {};
}

std::string TaskSession::stop() {
  if (!view_.running) return "no task is running";
  end_trial();
  view_.running = false;
  changed();
  if (!setup_.write_report) return {};
  TaskSessionRecord record;
  record.target = *target_;
  record.landmarks = &*setup_.landmarks;
  record.trials = std::move(trials_);
  record.started_ns = session_started_ns_;
  try {
    view_.report = setup_.write_report(record);
  } catch (const std::exception& e) {
    view_.note = std::string("the report was not written: ") + e.what();
  }
  trials_ = std::move(record.trials);
  return {};
}

void TaskSession::finish() {
  if (view_.running) stop();
}

void TaskSession::replay_marks(std::vector<std::uint64_t> ticks) {
  std::sort(ticks.begin(), ticks.end());
  replay_ticks_ = std::move(ticks);
  next_replay_ = 0;
}

}  // namespace palp::net
