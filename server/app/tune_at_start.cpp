// palpd --tune: see tune_at_start.hpp.
#include "app/tune_at_start.hpp"

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <thread>

#include <toml++/toml.h>

#include "base/errors.hpp"
#include "cli_common/model_setup.hpp"
#include "io/ct_io.hpp"
#include "prep/prep.hpp"
#include "scene/trajectory.hpp"
#include "tune/tuner.hpp"

namespace palp::app {
namespace {

namespace fs = std::filesystem;

// FNV-1a, 64 bits: detects changed maps, not an adversary (the cache is the user's own).
struct Fnv {
  std::uint64_t h = 1469598103934665603ull;
  void add(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  void add(const std::string& s) {
    add(s.data(), s.size());
    add("\0", 1);
  }
  void add_file(const fs::path& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw InputError("palpd --tune: cannot read " + path.string());
    std::vector<char> buffer(1 << 20);
    while (f) {
      f.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
      add(buffer.data(), static_cast<std::size_t>(f.gcount()));
    }
  }
};

std::string number(double v) {
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

std::string label(const std::string& tool, const SamplerConfig& c) {
  return tool + " " + to_string(c.gradient) + " " + to_string(c.storage);
}

struct Cached {
  std::string tool;
  SamplerConfig sampler;
  std::string summary;
};

// The cached choice, or nothing for a missing or unreadable file (then tuned again).
std::optional<Cached> read_cached(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::nullopt;
  try {
    const toml::table t = toml::parse_file(path.string());
    Cached c;
    c.tool = t["tool"].value_or(std::string());
    c.sampler.gradient = parse_gradient_scheme(t["scheme"].value_or(std::string()));
    c.sampler.storage = parse_storage(t["storage"].value_or(std::string()));
    c.summary = t["summary"].value_or(std::string());
    (void)parse_tool(c.tool);
    return c;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palpd: --tune: ignoring the unreadable cache %s (%s)\n",
                 path.string().c_str(), e.what());
    return std::nullopt;
  }
}

std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') out += '\\';
    if (static_cast<unsigned char>(ch) >= 0x20) out += ch;
  }
  return out + "\"";
}

// Written beside and renamed, so a crash never leaves half a cache entry.
void write_cached(const fs::path& path, const Cached& c, const std::string& about) {
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream f(tmp);
    f << "# palpd --tune: " << about << "\n";
    f << "tool = " << toml_string(c.tool) << "\n";
    f << "scheme = " << toml_string(to_string(c.sampler.gradient)) << "\n";
    f << "storage = " << toml_string(to_string(c.sampler.storage)) << "\n";
    f << "summary = " << toml_string(c.summary) << "\n";
    if (!f) {
      std::fprintf(stderr, "palpd: --tune: could not write the cache %s\n", tmp.string().c_str());
      fs::remove(tmp, ec);
      return;
    }
  }
  fs::rename(tmp, path, ec);
  if (ec) fs::remove(tmp, ec);
}

}  // namespace

std::string tune_cache_key(const std::string& prep_dir, double map_spacing_mm,
                           const std::string& tool, double rate_hz, const ForceParams& p,
                           const std::string& machine) {
  Fnv h;
  // v2: each tick judged against the force then (docs/tuning.md); a choice cached under v1's
  // whole-run RMS tolerance is not reused. The tolerance palpd tunes with is part of the key.
  h.add("palpd-tune-v2");
  const tune::Tolerance tol;
  for (double v :
       {tol.rel, tol.abs_n, tol.beyond_share, tol.max_factor, tol.tick_budget, tol.time_tie})
    h.add(number(v));
  h.add_file(fs::path(prep_dir) / kSurfaceDistanceFile);
  h.add_file(fs::path(prep_dir) / kBoneDistanceFile);
  h.add(number(map_spacing_mm));  // the maps refined in memory or not (scene/scene_maps.hpp)
  h.add(parse_tool(tool).name);
  h.add(number(rate_hz));
  for (double v : {p.c, p.k, p.bone_fmax, p.bone_flip, p.grad_epsilon, p.direction_epsilon,
                   p.bone_k, p.mu, p.skin_fmax, p.bone_fade_mm, p.bone_reach_mm})
    h.add(number(v));
  h.add(std::string(p.bone_enabled ? "1" : "0") + to_string(p.bone_mode) + to_string(p.model) +
        (p.bone_along_normal ? "1" : "0"));
  h.add(machine);
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h.h));
  return hex;
}

namespace {

// The one-line account of a tuning: candidates, the chosen tick and force difference, the maps.
std::string tune_summary(const tune::Outcome& o) {
  const tune::Judged& c = o.results[o.chosen];
  const tune::Judged& ref = o.results.front();
  char summary[320];
  std::snprintf(summary, sizeof summary,
                "of %zu candidates, tick p50 %.2f us (reference %.2f us), force difference "
                "beyond its tick's tolerance on %.2f %% of ticks (RMS %.4f N), maps %.1f MiB "
                "(reference %.1f MiB)%s",
                o.results.size(), c.measured.tick_p50_us, ref.measured.tick_p50_us,
                100.0 * c.measured.beyond_share, c.measured.rms_error_n,
                static_cast<double>(c.measured.map_bytes) / 1048576.0,
                static_cast<double>(ref.measured.map_bytes) / 1048576.0,
                c.accepted ? "" : "; NOTHING passes at this rate: the reference");
  return summary;
}

// What one tuning at start needs beyond the scene: the tool, rate, parameters, budget and cache.
struct TuneRun {
  const Tool& tool;
  double rate_hz;
  const ForceParams& params;
  double budget;
  std::chrono::steady_clock::time_point start;
  std::string machine;
  fs::path cache_file;
  bool quiet;
};

// Tunes now and caches the choice; over the budget, nothing (out.note says so, on stderr too).
std::optional<Cached> tune_now(const Scene& scene, const TuneRun& run, StartTuning& out) {
  const SceneMaps maps = read_scene_maps(scene);  // as the scene's sampler has them
  tune::Setup setup;
  setup.tool = run.tool.name;
  setup.rate_hz = run.rate_hz;
  setup.params = run.params;
  setup.budget_s =
      run.budget -
      std::chrono::duration<double>(std::chrono::steady_clock::now() - run.start).count();
  if (!run.quiet)
    std::fprintf(stderr, "palpd: --tune: tuning %s at %g Hz on this scene (budget %g s)...\n",
                 run.tool.name.c_str(), run.rate_hz, run.budget);
  try {
    if (setup.budget_s <= 0.0)
      throw tune::OverBudget("tune: over the time budget of " + number_text(run.budget) +
                             " s (reading the maps)");
    const tune::Outcome o = tune::tune(maps.surf, maps.bone, setup);
    const tune::Judged& c = o.results[o.chosen];
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - run.start).count();
    Cached choice{c.candidate.tool, c.candidate.sampler, tune_summary(o)};
    char note[64];
    std::snprintf(note, sizeof note, "tuned in %.1f s: ", seconds);
    out.note = note + choice.summary;
    write_cached(run.cache_file, choice,
                 "scene " + scene.source + " (" + scene.prep_dir + "), tool " + run.tool.name +
                     ", rate " + number(run.rate_hz) + " Hz, " + run.machine);
    return choice;
  } catch (const tune::OverBudget& e) {
    out.note = std::string(e.what()) + ": running the defaults (" + run.tool.name + " " +
               to_string(scene.fields->config().gradient) + " " +
               to_string(scene.fields->config().storage) +
               "); raise --tune-budget-s, or run palp tune --out FILE once and start palpd "
               "with --config FILE";
    std::fprintf(stderr, "palpd: --tune: %s\n", out.note.c_str());
    return std::nullopt;
  }
}

// The chosen tool, and the scene's sampler rebuilt when the choice stores its maps otherwise.
void apply_choice(const Cached& choice, Scene& scene, Tool& tool) {
  tool = parse_tool(choice.tool);
  const SamplerConfig now = scene.fields->config();
  if (now.gradient != choice.sampler.gradient || now.storage != choice.sampler.storage) {
    // the whole sampler goes before the new one is built: one set of maps at a time
    scene.fields.reset();
    SceneMaps maps = read_scene_maps(scene);
    scene.fields = std::make_shared<const FieldSampler>(std::move(maps.surf), std::move(maps.bone),
                                                        choice.sampler);
  }
}

}  // namespace

StartTuning tune_at_start(const cli::Args& args, Scene& scene, Tool& tool,
                          const ForceParams& params, double rate_hz, bool quiet) {
  if (!args.has("tune")) {
    if (args.get("tune-budget-s")) throw UsageError("--tune-budget-s needs --tune");
    return {};
  }
  if (args.get("device").value_or("").rfind("replay:", 0) == 0)
    throw UsageError("--tune does not apply to a replay: it runs the recording's configuration");
  const double budget = args.number("tune-budget-s", kDefaultTuneBudgetS);
  if (!(budget >= 0.001 && budget <= 3600.0))
    throw UsageError("--tune-budget-s must be in [0.001, 3600]");

  const auto start = std::chrono::steady_clock::now();
  const std::string machine = tune::machine_class();
  const std::string key =
      tune_cache_key(scene.prep_dir, scene.map_spacing_mm, tool.name, rate_hz, params, machine);
  std::string cache_dir = scene_options(args).cache_dir;
  if (cache_dir.empty()) cache_dir = default_scene_cache_dir();
  const fs::path cache_file = fs::path(cache_dir) / "tune" / (key + ".toml");

  StartTuning out;
  std::optional<Cached> choice = read_cached(cache_file);
  if (choice) {
    out.cached = true;
    out.note = "cached (" + cache_file.string() + "): " + choice->summary;
  } else {
    choice =
        tune_now(scene, {tool, rate_hz, params, budget, start, machine, cache_file, quiet}, out);
    if (!choice) return out;
  }
  out.choice = label(choice->tool, choice->sampler);
  apply_choice(*choice, scene, tool);
  if (!quiet) std::fprintf(stderr, "palpd: --tune: %s, %s\n", out.choice.c_str(), out.note.c_str());
  return out;
}

}  // namespace palp::app
