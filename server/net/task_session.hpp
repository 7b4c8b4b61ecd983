// palpd's training task, live (issue 40): the task the instructor started, its trials, the marks
// and their scores (common/training/task.hpp), fed from the loop's published snapshots.
//
// Never in the haptic tick: the loop publishes snapshots as it always does; the network thread's
// snapshot tap (Server::add_snapshot_tap) hands each one to offer(), which keeps one TrialSample
// every 1 / sample_rate_hz s in a buffer preallocated at construction (max_samples: beyond it
// samples are dropped and counted, never waited for or grown) and watches the device's mark
// button (rt::kMarkButton: a rising edge marks). Commands (start, mark, next trial, stop) come
// from the same thread, so nothing here locks. Points are converted from the scene frame to the
// patient's LPS world frame with the grid's placement before scoring; the wire carries them in
// the scene frame again (clients draw in it).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "anatomy/landmarks.hpp"
#include "base/volume.hpp"
#include "rt/snapshot.hpp"
#include "training/task.hpp"

namespace palp::net {

// One trial as scored at its end, with what it was scored from (the session report draws it).
struct ScoredTrial {
  int number = 0;  // 1, 2, ...
  std::vector<training::TrialSample> samples;
  std::vector<training::Mark> marks;
  training::TrialScore score;
  std::string error;  // scoring failed: why (then `score` is empty)
};

// A finished session, handed to the report writer.
struct TaskSessionRecord {
  training::TaskTarget target;
  const anatomy::Landmarks* landmarks = nullptr;
  std::vector<ScoredTrial> trials;
  std::int64_t started_ns = 0;  // CLOCK_MONOTONIC of the first trial's start
};

// A landmark as the clients draw it: scene frame, named.
struct WireLandmark {
  std::string name, kind;
  Vec3d point{};  // scene frame, mm
};
inline constexpr std::size_t kMaxWireLandmarks = 1024;
// The landmarks as points for the clients (ribs: at most 8 points each); UsageError past
// kMaxWireLandmarks.
std::vector<WireLandmark> wire_landmarks(const anatomy::Landmarks& landmarks, const Grid& grid);

struct TaskSetup {
  std::optional<anatomy::Landmarks> landmarks;  // none: every task start is refused
  std::string landmarks_source;                 // the file (or scene) they came from
  Grid grid;  // the scene's grid: its placement maps scene -> LPS (world_of_scene)
  double sample_rate_hz = 100.0;                // TrialSamples kept per second
  std::size_t max_samples = 60000;              // per trial (10 min at 100 Hz), preallocated
  std::size_t max_marks = 32;                   // per trial; more are refused and counted
  std::size_t max_trials = 64;                  // per session; then the session must stop
  // Writes the session's report when it ends (task stop, palpd's exit); returns the path
  // written, throws palp::Error on failure. Unset: no report.
  std::function<std::string(const TaskSessionRecord&)> write_report;
  // Told each mark with the tick it was taken at (recordings keep them: NAME.marks.csv).
  std::function<void(std::uint64_t seq, std::int64_t t_ns)> on_mark;
};

// What the status says; the wire view for a client is made from it (task_messages.hpp).
struct TaskState {
  bool running = false;
  std::string task;  // describe(spec), "" before any task
  int trial = 0;
  std::size_t marks = 0, trials_scored = 0;
  std::optional<training::MarkScore> last_mark;  // LPS
  std::optional<Vec3d> last_mark_scene, target_scene;
  std::uint64_t samples_dropped = 0, marks_dropped = 0;
  std::string note, report;
  std::uint64_t revision = 0;
};

class TaskSession {
 public:
  explicit TaskSession(TaskSetup setup);

  // The snapshot tap (network thread): a sample at the sample rate, and a mark on the mark
  // button's rising edge. Never allocates.
  void offer(const rt::Snapshot& snapshot);
  // Commands (network thread): "" when done, else why not.
  std::string start(const training::TaskSpec& spec);
  std::string mark();
  std::string next_trial();
  std::string stop();
  // palpd's exit: a running session is stopped (scored, its report written).
  void finish();

  const TaskState& view() const { return view_; }
  std::uint64_t revision() const { return view_.revision; }
  bool has_landmarks() const { return setup_.landmarks.has_value(); }
  const std::vector<WireLandmark>& landmarks_for_clients() const { return wire_; }
  const std::string& landmarks_source() const { return setup_.landmarks_source; }
  const std::vector<ScoredTrial>& trials() const { return trials_; }
  std::size_t samples_in_trial() const { return samples_.size(); }
  // Replay: marks at these ticks (the recorded ones, NAME.marks.csv), as button presses.
  void replay_marks(std::vector<std::uint64_t> ticks);

 private:
  std::string mark_now(const char* by);
  void begin_trial(std::int64_t t_ns);
  void end_trial();
  void score_last_mark();
  void changed() { ++view_.revision; }
  training::TrialSample sample_of(const rt::Snapshot& snapshot) const;

  TaskSetup setup_;
  std::vector<WireLandmark> wire_;
  std::optional<training::TaskTarget> target_;
  TaskState view_;
  std::vector<training::TrialSample> samples_;  // this trial's, capacity max_samples
  std::vector<training::Mark> marks_;           // this trial's, capacity max_marks
  std::vector<ScoredTrial> trials_;
  // The newest snapshot seen, as a sample (t absolute, s on CLOCK_MONOTONIC): what a mark
  // command marks.
  training::TrialSample latest_{};
  std::int64_t latest_t_ns_ = 0;
  std::uint64_t latest_seq_ = 0;
  bool have_latest_ = false;
  std::int64_t trial_t0_ns_ = 0;  // 0: the trial starts at the next snapshot
  std::int64_t next_sample_ns_ = 0;
  std::int64_t session_started_ns_ = 0;
  std::uint32_t last_buttons_ = 0;
  std::vector<std::uint64_t> replay_ticks_;  // sorted
  std::size_t next_replay_ = 0;
};

}  // namespace palp::net
