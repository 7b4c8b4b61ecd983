// A scored two-trial PTCD session on the inline landmarks (training_landmarks.hpp) for the
// report's and the cohort CSV's tests: trial 1 slides superior at 20 mm/s and marks the 9/10
// space (4.5 mm from its point), trial 2 presses on rib 9 and marks it.
#pragma once

#include <string>
#include <vector>

#include "support/training_landmarks.hpp"
#include "training/report.hpp"

namespace palp::testing {

// A straight slide on the right flank at y = 0: z from z0 at 20 mm/s for `seconds`, in contact
// from 0.1 s, the normal force ramping as 5 N/s.
inline std::vector<training::TrialSample> slide_samples(double z0, double seconds) {
  std::vector<training::TrialSample> samples;
  const int n = static_cast<int>(seconds * 1000.0 + 0.5);
  for (int i = 0; i <= n; ++i) {
    training::TrialSample s;
    s.t = i * 0.001;
    s.device_point = {-172.0, 0.0, z0 + 20.0 * s.t};
    s.skin_point = {-170.0, 0.0, z0 + 20.0 * s.t};
    s.in_contact = i >= 100;
    s.normal_force = s.in_contact ? 5.0 * s.t : 0.0;
    samples.push_back(s);
  }
  return samples;
}

inline training::Session ptcd_session(const std::string& trainee = "trainee-7") {
  using namespace training;
  Session session;
  session.id = "session-1";
  session.trainee = trainee;
  session.scene = "inline";
  session.tool = "finger:7";
  session.landmarks = torso_landmarks();
  session.target = resolve_target(TaskSpec{}, session.landmarks);
  for (int number = 1; number <= 2; ++number) {
    Trial trial;
    trial.number = number;
    // Trial 1 ends at z = 60 (mark at t = 0.9: z = 58); trial 2 at z = 80 (mark: z = 78, rib 9).
    trial.samples = slide_samples(number == 1 ? 40.0 : 60.0, 1.0);
    trial.marks = {mark_at(trial.samples, 0.9005)};
    trial.score = score_trial(session.target, session.landmarks, trial.samples, trial.marks);
    session.trials.push_back(trial);
  }
  return session;
}

}  // namespace palp::testing
