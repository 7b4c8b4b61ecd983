// palpview's frame-time split: per-phase times collected while live, summarised (mean, p50,
// p95, max) for the exit line and --stats-json.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

namespace palp::view {

// Per-phase frame times (ms).
struct PhaseTimes {
  std::vector<double> receive, deformation, upload, upload_bytes, render;
  std::vector<double> render_modified, render_unchanged;  // render ms with / without re-upload
  std::int64_t deform_active = 0;
  std::int64_t roi_voxels_sum = 0;
};

// n, mean, p50, p95 and max of `v` (n only when empty).
nlohmann::json summary(std::vector<double> v);

// The mean of `v`, 0 when empty.
double mean_of(const std::vector<double>& v);

}  // namespace palp::view
