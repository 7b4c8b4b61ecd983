// palpview's frame-time split: see frame_times.hpp.
#include "app/frame_times.hpp"

#include <time.h>

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

void PhaseTimes::add_deformation(const DeformResult& result, double cpu_ms,
                                 std::span<const DeformContact> contacts) {
  if (!result.active) return;
  deform_cpu.push_back(cpu_ms);
  deform_solve.push_back(1e3 * result.solve_seconds);
  deform_resample.push_back(1e3 * result.resample_seconds);
  roi_elements.push_back(static_cast<double>(result.elements));
  last_contacts.assign(contacts.begin(), contacts.end());
}

double thread_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

nlohmann::json deformation_split_json(const PhaseTimes& t) {
  nlohmann::json j;
  j["cpu_ms"] = summary(t.deform_cpu);
  j["solve_ms"] = summary(t.deform_solve);
  j["resample_ms"] = summary(t.deform_resample);
  j["roi_elements"] = summary(t.roi_elements);
  j["per_frame"] = {{"cpu_ms", t.deform_cpu},
                    {"solve_ms", t.deform_solve},
                    {"resample_ms", t.deform_resample},
                    {"roi_elements", t.roi_elements}};
  nlohmann::json contacts = nlohmann::json::array();
  for (const DeformContact& c : t.last_contacts)
    contacts.push_back({{c.x.x, c.x.y, c.x.z}, {c.p.x, c.p.y, c.p.z}});
  j["last_contacts"] = contacts;
  return j;
}

double mean_of(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

}  // namespace palp::view
