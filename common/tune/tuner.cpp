#include "tune/tuner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <thread>
#include <utility>

#include "base/errors.hpp"
#include "scene/trajectory_gen.hpp"

namespace palp::tune {
namespace {

using Clock = std::chrono::steady_clock;

// Timing repeats tick about this many rows of each path, spread over it: enough ticks for a p99,
// bounded whatever the rate.
constexpr std::size_t kTimedRowsPerPath = 1500;

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::string format(const char* fmt, double a, double b) {
  char text[160];
  std::snprintf(text, sizeof text, fmt, a, b);
  return text;
}

// The forces of one candidate along every trajectory (a fresh State per trajectory), and the
// time of each tick.
struct Run {
  std::vector<Vec3d> force, normal;  // f_device; the mean skin normal of the points in contact
  std::vector<double> tick_us;
};

// Every row, or (max_rows > 0) about max_rows of each path, evenly spread over it (a stride).
Run run(const Model& model, const std::vector<NamedTrajectory>& paths, bool keep_forces,
        std::size_t max_rows = 0) {
  Run r;
  for (const NamedTrajectory& path : paths) {
    State st = make_state(model);
    const std::size_t stride =
        max_rows > 0 ? std::max<std::size_t>(1, (path.path.size() + max_rows - 1) / max_rows) : 1;
    for (std::size_t k = 0; k < path.path.size(); k += stride) {
      const TrajectorySample& row = path.path[k];
      const auto t0 = Clock::now();
      tick(model, st, row.pose);
      const auto t1 = Clock::now();
      r.tick_us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
      if (keep_forces) {
        r.force.push_back(st.f_device);
        Vec3d n{};
        for (std::size_t i = 0; i < st.normal.size(); ++i)
          if (st.in_contact[i]) n += st.normal[i];
        const double len = norm(n);
        r.normal.push_back(len > 0.0 ? n * (1.0 / len) : Vec3d{});
      }
    }
  }
  return r;
}

std::size_t sampler_bytes(const FieldSampler& f) {
  return f.grid().voxel_count() * (f.bytes_per_voxel() + (f.has_bone_beneath() ? 4 : 0));
}

// A candidate's forces against the reference's (`ref`), and its tick timed in repeats of the
// whole set, each tick timed (medians over the repeats).
Measured measure(const Model& model, const std::vector<NamedTrajectory>& paths, const Run& ref,
                 const Setup& setup) {
  const Run r = run(model, paths, true);
  Measured m = compare_forces(r.force, ref.force, ref.normal, setup.tolerance);
  std::vector<double> p50, p99;
  for (int k = 0; k < setup.repeats; ++k) {
    Run timed = run(model, paths, false, kTimedRowsPerPath);
    p50.push_back(quantile(timed.tick_us, 0.50));
    p99.push_back(quantile(timed.tick_us, 0.99));
  }
  m.tick_p50_us = median(p50);
  m.tick_p99_us = median(p99);
  return m;
}

// error / allowed; with nothing allowed (a zero floor where the reference is 0), any error is
// infinitely many tolerances and none is 0.
double ratio(double error, double allowed) {
  if (allowed > 0.0) return error / allowed;
  return error > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
}

// Why a candidate's forces are told from the reference's, or "" when they are not.
std::string force_verdict(const Measured& m, const Tolerance& tol) {
  char text[240];
  if (m.beyond_share > tol.beyond_share) {
    std::snprintf(text, sizeof text,
                  "force error: %.1f %% of ticks beyond their tolerance (> %.1f %%)",
                  100.0 * m.beyond_share, 100.0 * tol.beyond_share);
  } else if (m.worst_ratio > tol.max_factor) {
    std::snprintf(text, sizeof text,
                  "force error: %.3f N where %.3f N allowed (reference %.3f N), > %g tolerances",
                  m.worst_error_n, m.worst_allowed_n, m.worst_force_n, tol.max_factor);
  } else if (m.step_ratio > 1.0) {
    std::snprintf(text, sizeof text,
                  "per-tick step above the reference's by %.2f tolerances of its tick (largest "
                  "excess %.3f N)",
                  m.step_ratio, m.step_excess_n);
  } else {
    return "";
  }
  return text;
}

}  // namespace

double allowed_n(const Tolerance& tol, double reference_n) {
  return std::max(tol.abs_n, tol.rel * reference_n);
}

Measured compare_forces(const std::vector<Vec3d>& f, const std::vector<Vec3d>& ref,
                        const std::vector<Vec3d>& normal, const Tolerance& tol) {
  if (f.size() != ref.size() || normal.size() != ref.size())
    throw UsageError("tune: a candidate's forces and the reference's differ in length");
  Measured m;
  double e2 = 0.0, l2 = 0.0;
  std::size_t beyond = 0;
  for (std::size_t t = 0; t < f.size(); ++t) {
    const Vec3d d = f[t] - ref[t];
    const double e = norm(d);
    const double allowed = allowed_n(tol, norm(ref[t]));
    e2 += e * e;
    m.max_error_n = std::max(m.max_error_n, e);
    if (e > allowed) ++beyond;
    if (ratio(e, allowed) > m.worst_ratio) {
      m.worst_ratio = ratio(e, allowed);
      m.worst_error_n = e, m.worst_allowed_n = allowed, m.worst_force_n = norm(ref[t]);
    }
    const Vec3d lateral = d - dot(d, normal[t]) * normal[t];  // the friction part
    l2 += dot(lateral, lateral);
    if (t > 0) {
      const double excess = norm(f[t] - f[t - 1]) - norm(ref[t] - ref[t - 1]);
      m.step_excess_n = std::max(m.step_excess_n, excess);
      m.step_ratio = std::max(m.step_ratio, ratio(excess, allowed));
    }
  }
  const double n = static_cast<double>(std::max<std::size_t>(f.size(), 1));
  m.rms_error_n = std::sqrt(e2 / n);
  m.lateral_rms_error_n = std::sqrt(l2 / n);
  m.beyond_share = static_cast<double>(beyond) / n;
  return m;
}

std::size_t judge(std::vector<Judged>& results, const Tolerance& tol, double period_us) {
  if (results.empty()) throw UsageError("tune: no candidates");
  const double budget_us = tol.tick_budget * period_us;
  for (std::size_t i = 0; i < results.size(); ++i) {
    Judged& j = results[i];
    const Measured& m = j.measured;
    j.chosen = false;
    j.reference = i == 0;
    const std::string force = i > 0 ? force_verdict(m, tol) : std::string();
    if (m.tick_p99_us > budget_us) {
      j.accepted = false;
      j.reason = format("too slow: tick p99 %.2f us > %.2f us", m.tick_p99_us, budget_us);
    } else if (!force.empty()) {
      j.accepted = false;
      j.reason = force;
    } else {
      j.accepted = true;
      j.reason = "accepted";
    }
  }
  // The fastest accepted tick; every accepted candidate within tol.time_tie of it counts as
  // equally fast (timings repeat only to a few per cent), and among those the least memory,
  // then the smallest force error, then the order wins - so the choice does not flip with noise.
  double fastest = 0.0;
  bool any = false;
  for (const Judged& j : results)
    if (j.accepted && (!any || j.measured.tick_p50_us < fastest)) {
      fastest = j.measured.tick_p50_us;
      any = true;
    }
  if (!any) {
    results[0].chosen = true;
    return 0;
  }
  std::size_t best = results.size();
  for (std::size_t i = 0; i < results.size(); ++i) {
    const Judged& j = results[i];
    if (!j.accepted || j.measured.tick_p50_us > fastest * (1.0 + tol.time_tie)) continue;
    if (best == results.size()) {
      best = i;
      continue;
    }
    const Measured& m = j.measured;
    const Measured& b = results[best].measured;
    if (m.map_bytes < b.map_bytes || (m.map_bytes == b.map_bytes && m.rms_error_n < b.rms_error_n))
      best = i;
  }
  results[best].chosen = true;
  return best;
}

std::vector<std::string> footprint_tools(const Tool& tool) {
  std::vector<std::string> out;
  if (tool.kind == ToolKind::Probe) {
    int nx = tool.nx, ny = tool.ny;
    for (;;) {
      out.push_back("probe:" + std::to_string(nx) + "x" + std::to_string(ny));
      if (nx == 1 && ny == 1) break;
      nx = std::max(1, (nx + 1) / 2);
      ny = std::max(1, (ny + 1) / 2);
    }
    return out;
  }
  const std::string kind = tool.kind == ToolKind::TwoFinger ? "twofinger:" : "finger:";
  for (int n : {37, 19, 7, 1})
    if (n <= tool.per_pad) out.push_back(kind + std::to_string(n));
  return out;
}

std::vector<NamedTrajectory> palpation_trajectories(const FieldSampler& fields, const Tool& tool,
                                                    double rate_hz) {
  std::vector<NamedTrajectory> out;
  const double offset = pad_offset(tool);
  // Where the scene lets us: an anchor on the anterior skin for the flat-frame paths.
  try {
    const SurfaceAnchor anchor = find_surface_anchor(fields, ApproachSide::Auto);
    PressHoldSpec press;
    press.rate_hz = rate_hz;
    press.depth_mm = 6.0;
    press.press_s = 0.5;
    press.hold_s = 0.3;
    out.push_back({"press 6 mm", press_hold(anchor, offset, press)});
    SlideSpeedSpec slide;
    slide.rate_hz = rate_hz;
    slide.depth_mm = 4.0;
    slide.press_s = 0.3;
    slide.speeds_mm_s = {20.0, 100.0, 300.0};
    slide.segment_s = 0.3;
    slide.hold_s = 0.2;
    out.push_back({"slide 4 mm at 20/100/300 mm/s", slide_speed(anchor, offset, slide)});
  } catch (const InputError&) {
  }
  for (double speed : {20.0, 100.0}) {
    try {
      RibsSpec ribs;
      ribs.rate_hz = rate_hz;
      ribs.speed_mm_s = speed;
      ribs.depth_mm = 6.0;
      ribs.press_s = 0.3;
      std::ostringstream name;
      name << "ribs 6 mm at " << speed << " mm/s";
      out.push_back({name.str(), ribs_slide(fields, offset, ribs)});
    } catch (const InputError&) {
    }
  }
  if (out.empty())
    throw InputError("tune: no palpation path fits this scene (no skin reached from any side)");
  return out;
}

Outcome tune(const DistanceMap& surf, const DistanceMap& bone, const Setup& setup,
             Progress progress) {
  if (!(setup.rate_hz > 0.0)) throw UsageError("tune: the rate must be positive");
  if (setup.repeats < 1) throw UsageError("tune: at least one timing repeat");
  const Tool given = parse_tool(setup.tool);
  const std::vector<std::string> tools = footprint_tools(given);
  const Clock::time_point start = Clock::now();
  const auto check_budget = [&](const char* where) {
    if (setup.budget_s <= 0.0) return;
    const double spent = std::chrono::duration<double>(Clock::now() - start).count();
    if (spent > setup.budget_s)
      throw OverBudget(
          format("tune: over the time budget of %g s (%.1f s spent, ", setup.budget_s, spent) +
          where + ")");
  };

  // One sampler per (scheme, storage); the reference's first.
  const GradientScheme schemes[] = {GradientScheme::PrecomputedField,
                                    GradientScheme::AnalyticTrilinear,
                                    GradientScheme::CentralDifference};
  const Storage storages[] = {Storage::Float32, Storage::Int16, Storage::Interleaved};
  std::vector<std::pair<SamplerConfig, std::shared_ptr<const FieldSampler>>> samplers;
  for (GradientScheme g : schemes)
    for (Storage s : storages) {
      const SamplerConfig config{g, s};
      samplers.emplace_back(config, std::make_shared<const FieldSampler>(surf, bone, config));
      check_budget("building the maps");
    }

  Outcome out;
  out.period_us = 1e6 / setup.rate_hz;
  const Tool reference_tool = parse_tool(tools.front());
  const std::vector<NamedTrajectory> paths =
      palpation_trajectories(*samplers.front().second, reference_tool, setup.rate_hz);
  for (const auto& p : paths) {
    out.trajectories.push_back(p.name);
    out.ticks += p.path.size();
  }

  // The reference's forces.
  const Model reference(samplers.front().second, reference_tool, setup.params);
  const Run ref = run(reference, paths, true);
  double sq = 0.0;
  std::size_t light = 0;
  for (const Vec3d& f : ref.force) {
    sq += dot(f, f);
    light += setup.tolerance.rel * norm(f) < setup.tolerance.abs_n;
  }
  const double n_ref = static_cast<double>(std::max<std::size_t>(ref.force.size(), 1));
  out.reference_rms_force_n = std::sqrt(sq / n_ref);
  out.light_share = static_cast<double>(light) / n_ref;

  std::size_t count = tools.size() * samplers.size();
  std::size_t index = 0;
  for (const std::string& tool_name : tools) {
    const Tool tool = parse_tool(tool_name);
    for (const auto& [config, fields] : samplers) {
      Judged j;
      j.candidate = {tool_name, config};
      j.measured = measure(Model(fields, tool, setup.params), paths, ref, setup);
      j.measured.map_bytes = sampler_bytes(*fields);
      out.results.push_back(std::move(j));
      if (progress) progress(out.results.back(), index, count);
      ++index;
      if (index < count) check_budget("measuring the candidates");
    }
  }
  out.chosen = judge(out.results, setup.tolerance, out.period_us);
  return out;
}

std::string machine_class() {
  std::string cpu = "unknown CPU";
  std::ifstream info("/proc/cpuinfo");
  for (std::string line; std::getline(info, line);)
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  return std::to_string(std::thread::hardware_concurrency()) + " cores, " + cpu;
}

}  // namespace palp::tune
