// palpd's Commands: see palpd_control.hpp.
#include "app/palpd_control.hpp"

#include <ctime>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "model/tool.hpp"
#include "scene/trajectory.hpp"

namespace palp::app {
namespace {

// Now, as 2026-11-24T12:00:00Z.
std::string utc_now_text() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

}  // namespace

std::vector<std::string> param_assignments(const ForceParams& p) {
  return {"c=" + number_text(p.c),
          "k=" + number_text(p.k),
          "bone_fmax=" + number_text(p.bone_fmax),
          "bone_flip=" + number_text(p.bone_flip),
          std::string("bone_enabled=") + (p.bone_enabled ? "1" : "0"),
          "grad_epsilon=" + number_text(p.grad_epsilon),
          "direction_epsilon=" + number_text(p.direction_epsilon),
          std::string("bone_mode=") + (p.bone_mode == BoneMode::Robust ? "1" : "0"),
          "bone_k=" + number_text(p.bone_k),
          std::string("model=") + (p.model == ModelKind::Palp ? "1" : "0"),
          "mu=" + number_text(p.mu),
          "skin_fmax=" + number_text(p.skin_fmax),
          "bone_fade_mm=" + number_text(p.bone_fade_mm),
          "bone_reach_mm=" + number_text(p.bone_reach_mm),
          std::string("bone_along_normal=") + (p.bone_along_normal ? "1" : "0")};
}

PalpdControl::PalpdControl(rt::HapticLoop& loop, std::shared_ptr<const FieldSampler> fields,
                           rt::Device& device, rt::RecordingMetadata metadata,
                           std::string record_dir)
    : loop_(loop),
      fields_(std::move(fields)),
      remote_(dynamic_cast<rt::RemoteDevice*>(&device)),
      metadata_(std::move(metadata)),
      record_dir_(std::move(record_dir)) {}

std::string PalpdControl::set_tool(const std::string& name) {
  if (recording()) return kLockedWhileRecording;
  const Tool tool = parse_tool(name);
  const auto current = loop_.model();
  const ForceParams params = tool.kind == current->tool().kind
                                 ? current->params()
                                 : model_params(current->params().model, tool.kind);
  loop_.swap_model(std::make_shared<const Model>(fields_, tool, params, current->layers_ptr()));
  return {};
}

std::string PalpdControl::set_parameter(const std::string& name, double value) {
  if (recording()) return kLockedWhileRecording;
  // The heart rate goes to the loop's atomic, read between ticks: no new model, contacts kept.
  if (name == "pulse_bpm") {
    if (std::string why = rt::pulse_bpm_refusal(value); !why.empty()) return why;
    loop_.set_pulse_bpm(value);
    return {};
  }
  const auto current = loop_.model();
  ForceParams params = current->params();
  set_param(params, name, value);
  validate(params);
  loop_.swap_model(
      std::make_shared<const Model>(fields_, current->tool(), params, current->layers_ptr()));
  return {};
}

std::string PalpdControl::set_paused(bool paused) {
  loop_.set_paused(paused);
  return {};
}

std::string PalpdControl::recentre() {
  if (loop_.config().registration.is_identity())
    return "this device moves in the scene frame (no registration): nothing to re-centre";
  loop_.request_recentre();
  return {};
}

std::string PalpdControl::start_recording(const std::string& name,
                                          const std::string& requested_by) {
  if (name.empty() || name.size() > 128 || name.find('/') != std::string::npos ||
      name.front() == '.')
    return "recording name must be a plain file name (no '/', not starting with '.')";
  for (const char ch : name)
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f)
      return "recording name must not hold control characters";
  return start(std::filesystem::path(record_dir_) / name, requested_by);
}

std::string PalpdControl::start(const std::filesystem::path& path,
                                const std::string& requested_by) {
  const std::lock_guard lock(mutex_);
  if (recorder_) return "already recording to " + recorder_->path();
  rt::RecordingMetadata meta = metadata_;
  const auto model = loop_.model();
  meta["tool"] = model->tool().name;
  meta["pulse-bpm"] = number_text(loop_.pulse_bpm());  // fixed while recording, as the rest
  meta["started-by"] = requested_by;
  meta["started-at"] = utc_now_text();
  const std::vector<std::string> params = param_assignments(model->params());
  for (const std::string& a : params) {
    const auto eq = a.find('=');
    meta["param." + a.substr(0, eq)] = a.substr(eq + 1);
  }
  const std::uint64_t first = loop_.stats().ticks;
  recorder_ = std::make_unique<rt::Recorder>(loop_.record_ring(), path.string(), meta, first);
  loop_.set_recording(true);
  return {};
}

namespace {

// The marks of a stopped recording beside it, as its own ticks: "" or why they were not written.
std::string write_marks(const rt::Recorder& done,
                        const std::vector<std::pair<std::uint64_t, std::int64_t>>& marks) {
  std::uint64_t first_seq = 0;
  std::int64_t first_t_ns = 0;
  if (marks.empty() || !done.first_recorded(first_seq, first_t_ns)) return {};
  std::vector<rt::RecordedMark> rows;
  for (const auto& [seq, t_ns] : marks)
    if (seq >= first_seq)
      rows.push_back({static_cast<double>(t_ns - first_t_ns) * 1e-9, seq - first_seq});
  try {
    rt::write_recording_marks(rt::marks_path_for(done.path()), rows);
  } catch (const std::exception& e) {
    return e.what();
  }
  return {};
}

}  // namespace

std::string PalpdControl::stop_recording() {
  std::unique_ptr<rt::Recorder> done;
  std::vector<std::pair<std::uint64_t, std::int64_t>> marks;
  {
    const std::lock_guard lock(mutex_);
    if (!recorder_) return "not recording";
    loop_.set_recording(false);
    done = std::move(recorder_);
    marks = std::exchange(marks_, {});
  }
  done->stop();
  return write_marks(*done, marks);
}

void PalpdControl::note_mark(std::uint64_t seq, std::int64_t t_ns) {
  const std::lock_guard lock(mutex_);
  if (recorder_ && marks_.size() < rt::kMaxRecordedMarks) marks_.emplace_back(seq, t_ns);
}

bool PalpdControl::recording() const {
  const std::lock_guard lock(mutex_);
  return recorder_ != nullptr;
}

bool PalpdControl::set_device_pose(const Pose& pose, std::int64_t received_ns) {
  if (!remote_) return false;
  remote_->submit(pose, received_ns);
  return true;
}

std::uint64_t PalpdControl::recorded() const {
  const std::lock_guard lock(mutex_);
  return recorder_ ? recorder_->count() : 0;
}

}  // namespace palp::app
