// palpview's frame-time split: per-phase times collected while live, summarised (mean, p50,
// p95, max) for the exit line and --stats-json.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "deform/skin_deformation.hpp"

namespace palp::view {

// Per-phase frame times (ms).
struct PhaseTimes {
  std::vector<double> receive, deformation, upload, upload_bytes, render;
  std::vector<double> render_modified, render_unchanged;  // render ms with / without re-upload
  std::int64_t deform_active = 0;
  std::int64_t roi_voxels_sum = 0;
  // The deformation update split, on frames where it was active: the calling thread's CPU time
  // (what the update cost, whoever else held the cores) beside the wall time above, the
  // ChainMail solve and the resampling (wall), and the ChainMail box's elements.
  std::vector<double> deform_cpu, deform_solve, deform_resample, roi_elements;
  std::vector<DeformContact> last_contacts;  // the last active frame's (volume frame, mm)

  // Notes one live frame's deformation (cpu_ms: the thread's CPU time across update()).
  void add_deformation(const DeformResult& result, double cpu_ms,
                       std::span<const DeformContact> contacts);
};

// The calling thread's CPU time (s), CLOCK_THREAD_CPUTIME_ID.
double thread_cpu_seconds();

// The deformation split of `t` for --stats-json: cpu/solve/resample summaries, the ROI, and the
// last active frame's contacts as [x, p] pairs (what tests/bench/bench_skin_deformation's
// palpview case reproduces).
nlohmann::json deformation_split_json(const PhaseTimes& t);

// n, mean, p50, p95 and max of `v` (n only when empty).
nlohmann::json summary(std::vector<double> v);

// The mean of `v`, 0 when empty.
double mean_of(const std::vector<double>& v);

}  // namespace palp::view
