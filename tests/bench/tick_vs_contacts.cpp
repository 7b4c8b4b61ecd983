// tick_vs_contacts — the force model's tick time against the number of contact points (the
// paper's Fig. 5b: update rate per number of proxies, with median and quartiles).
//
//   tick_vs_contacts --scene SCENE --out FILE.csv [--ticks N] [--rounds R] [--warmup W]
//                    [--tools T1,T2,...] [--cache-dir DIR]
//
// For every tool (default: finger:1/7/19/37 and probe grids of 2 ... 100 points, and the paper's
// ultrasound set-up probe:9x3) the tick is timed on its own with steady_clock, over the poses of
// the `palp traj ribs` path (the flat slide-speed path where the scene has no body axis) run back
// and forth, so the contacts are real. The tools are interleaved in R rounds of N/R ticks each so
// that load from other processes spreads evenly over them. Writes one CSV row per tool:
//   scene,tool,contacts,in_contact_mean,ticks,clock_ns,mean_ns,p1_ns,p25_ns,p50_ns,p75_ns,
//   p99_ns,whisker_lo_ns,whisker_hi_ns,rate_p50_khz
// (whiskers: the most extreme samples within 1.5 IQR of the quartiles; the clock's own cost,
// clock_ns, is included in every figure). It measures; it is not a test.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "base/errors.hpp"
#include "bench_main.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"
#include "scene/scene.hpp"
#include "scene/trajectory.hpp"
#include "scene/trajectory_gen.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using namespace palp;

constexpr const char* kUsage =
    "usage: tick_vs_contacts --scene SCENE --out FILE.csv [--ticks N] [--rounds R] [--warmup W]\n"
    "                        [--tools T1,T2,...] [--cache-dir DIR]\n";

const char* const kDefaultTools[] = {"finger:1",  "probe:1x2", "probe:2x2",  "finger:7",
                                     "probe:3x3", "probe:4x4", "finger:19",  "probe:5x5",
                                     "probe:9x3", "probe:6x6", "finger:37",  "probe:7x7",
                                     "probe:8x8", "probe:9x9", "probe:10x10"};

std::vector<std::string> split(std::string_view s, char sep) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t p = s.find(sep, start);
    out.emplace_back(s.substr(start, p == std::string_view::npos ? s.npos : p - start));
    if (p == std::string_view::npos) break;
    start = p + 1;
  }
  return out;
}

// Index into a path run back and forth: 0, 1, ..., n-1, n-2, ..., 1, 0, 1, ...
std::size_t ping_pong(std::size_t i, std::size_t n) {
  if (n < 2) return 0;
  const std::size_t period = 2 * (n - 1);
  const std::size_t r = i % period;
  return r < n ? r : period - r;
}

Trajectory default_path(const FieldSampler& fields, double offset) {
  try {
    return ribs_slide(fields, offset, RibsSpec{});
  } catch (const InputError&) {
    return slide_speed(find_surface_anchor(fields, ApproachSide::Auto), offset, SlideSpeedSpec{});
  }
}

// Median cost of one pair of clock reads (ns).
double clock_pair_ns() {
  std::vector<std::int64_t> samples(2001);
  for (auto& s : samples) {
    const auto t0 = Clock::now();
    const auto t1 = Clock::now();
    s = std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count();
  }
  std::nth_element(samples.begin(), samples.begin() + 1000, samples.end());
  return static_cast<double>(samples[1000]);
}

struct Bench {
  Tool tool;
  Model model;
  State state;
  Trajectory path;
  std::size_t next = 0;  // position on the ping-pong path
  std::vector<std::int64_t> ns;
  double in_contact_sum = 0.0;

  Bench(std::shared_ptr<const FieldSampler> fields, Tool t)
      : tool(t), model(std::move(fields), std::move(t)), state(make_state(model)) {}

  void run(std::size_t count, bool timed) {
    const std::size_t n = path.size();
    for (std::size_t i = 0; i < count; ++i) {
      const Pose& pose = path[ping_pong(next++, n)].pose;
      const auto t0 = Clock::now();
      tick(model, state, pose);
      const auto t1 = Clock::now();
      if (timed) {
        ns.push_back(std::chrono::duration_cast<std::chrono::nanoseconds>(t1 - t0).count());
        in_contact_sum += state.n_contact;
      }
    }
  }
};

// Nearest-rank percentile of sorted samples.
double rank(const std::vector<std::int64_t>& sorted, double p) {
  const double r = std::ceil(p * static_cast<double>(sorted.size()));
  const std::size_t i = static_cast<std::size_t>(std::max(r, 1.0)) - 1;
  return static_cast<double>(sorted[std::min(i, sorted.size() - 1)]);
}

int run(int argc, char** argv) {
  std::string scene_name, out, cache_dir;
  std::size_t ticks = 20000, rounds = 10, warmup = 2000;
  std::vector<std::string> tools(std::begin(kDefaultTools), std::end(kDefaultTools));
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(std::string(a) + " needs a value");
      return argv[++i];
    };
    auto count = [&]() -> std::size_t {
      const std::string v = value();
      char* end = nullptr;
      const unsigned long long n = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || n == 0 || n > 100000000ULL)
        throw UsageError(std::string(a) + " needs a whole number from 1 to 1e8");
      return static_cast<std::size_t>(n);
    };
    if (a == "--scene") {
      scene_name = value();
    } else if (a == "--out") {
      out = value();
    } else if (a == "--cache-dir") {
      cache_dir = value();
    } else if (a == "--ticks") {
      ticks = count();
    } else if (a == "--rounds") {
      rounds = count();
    } else if (a == "--warmup") {
      warmup = count();
    } else if (a == "--tools") {
      tools = split(value(), ',');
    } else if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    } else {
      throw UsageError("unknown argument '" + std::string(a) + "'");
    }
  }
  if (scene_name.empty() || out.empty()) throw UsageError("--scene and --out are required");
  rounds = std::min(rounds, ticks);

  SceneOptions options;
  options.cache_dir = cache_dir;
  const Scene scene = load_scene(scene_name, options);

  std::vector<Bench> benches;
  benches.reserve(tools.size());
  for (const std::string& name : tools) {
    Tool tool = parse_tool(name);
    const double offset = pad_offset(tool);
    Bench& b = benches.emplace_back(scene.fields, std::move(tool));
    b.path = default_path(*scene.fields, offset);
    b.ns.reserve(ticks);
  }
  const double clock_ns = clock_pair_ns();
  for (Bench& b : benches) b.run(warmup, false);
  for (std::size_t r = 0; r < rounds; ++r) {
    const std::size_t chunk = ticks / rounds + (r < ticks % rounds ? 1 : 0);
    for (Bench& b : benches) b.run(chunk, true);
  }

  std::FILE* f = std::fopen(out.c_str(), "w");
  if (!f) throw InputError("cannot write " + out);
  std::fprintf(f,
               "scene,tool,contacts,in_contact_mean,ticks,clock_ns,mean_ns,p1_ns,p25_ns,p50_ns,"
               "p75_ns,p99_ns,whisker_lo_ns,whisker_hi_ns,rate_p50_khz\n");
  std::printf("tick time on %s (%zu ticks per tool in %zu rounds, clock pair %.0f ns included)\n",
              scene.source.c_str(), ticks, rounds, clock_ns);
  for (Bench& b : benches) {
    std::vector<std::int64_t> s = b.ns;
    std::sort(s.begin(), s.end());
    double sum = 0.0;
    for (std::int64_t v : s) sum += static_cast<double>(v);
    const double mean = sum / static_cast<double>(s.size());
    const double p25 = rank(s, 0.25), p50 = rank(s, 0.50), p75 = rank(s, 0.75);
    const double iqr = p75 - p25;
    double lo = p25, hi = p75;
    for (std::int64_t v : s) {
      const double d = static_cast<double>(v);
      if (d >= p25 - 1.5 * iqr) lo = std::min(lo, d);
      if (d <= p75 + 1.5 * iqr) hi = std::max(hi, d);
    }
    const double in_contact = b.in_contact_sum / static_cast<double>(s.size());
    std::fprintf(f, "%s,%s,%zu,%.3f,%zu,%.0f,%.1f,%.0f,%.0f,%.0f,%.0f,%.0f,%.0f,%.0f,%.1f\n",
                 scene_name.c_str(), b.tool.name.c_str(), b.tool.points.size(), in_contact,
                 s.size(), clock_ns, mean, rank(s, 0.01), p25, p50, p75, rank(s, 0.99), lo, hi,
                 1e6 / p50);
    std::printf(
        "  %-12s %3zu points (%6.2f in contact)  p25 %6.0f  p50 %6.0f  p75 %6.0f  p99 %6.0f ns\n",
        b.tool.name.c_str(), b.tool.points.size(), in_contact, p25, p50, p75, rank(s, 0.99));
  }
  if (std::fclose(f) != 0) throw InputError("cannot write " + out);
  std::printf("wrote %s\n", out.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return palp::bench::bench_main("tick_vs_contacts", kUsage, run, argc, argv);
}
