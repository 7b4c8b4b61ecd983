// palpview's frame-time split: see frame_times.hpp.
#include "app/frame_times.hpp"

#include <algorithm>
#include <numeric>

namespace palp::view {

nlohmann::json summary(std::vector<double> v) {
  nlohmann::json j;
  j["n"] = v.size();
  if (v.empty()) return j;
  std::sort(v.begin(), v.end());
  const auto q = [&](double f) {
    return v[std::min(v.size() - 1, static_cast<std::size_t>(f * static_cast<double>(v.size())))];
  };
  j["mean"] = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  j["p50"] = q(0.5);
  j["p95"] = q(0.95);
  j["max"] = v.back();
  return j;
}

double mean_of(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

}  // namespace palp::view
