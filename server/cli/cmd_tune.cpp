// palp tune --scene S --tool T --rate HZ [--out FILE]: the cheapest model configuration for this
// scene, tool and loop rate that feels the same as the most accurate one (common/tune/tuner.hpp).
//   scene -> maps (d_surf, d_bone) -> tune (candidates measured on the palpation paths, judged)
//   -> table on stdout -> config file (palpd --config, palp run --config), CSV, chart (palpchart)
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "base/errors.hpp"
#include "cli/commands.hpp"
#include "cli_common/cli.hpp"
#include "cli_common/model_setup.hpp"
#include "io/ct_io.hpp"
#include "prep/prep.hpp"
#include "tune/tuner.hpp"

namespace palp::cli {
namespace {

namespace fs = std::filesystem;

constexpr const char* kTuneUsage =
    R"(usage: palp tune --scene SCENE --tool TOOL --rate HZ [--out FILE] [options]

Finds, for this scene, tool and loop rate, the cheapest configuration whose forces a hand cannot
tell from the most accurate one palp offers for that tool (precomputed gradient, float32 maps,
the tool's own contact points), with the tick well inside the loop period. Every candidate
(gradient scheme x map storage x contact points) is ticked along the palpation paths a hand uses
on this scene (a press, a slide at 20/100/300 mm/s, slides across the ribs at 20 and 100 mm/s,
at the loop rate) and compared with the reference tick by tick; its tick is timed in repeats
(medians). Each tick's tolerance is the larger of --tolerance-n and --tolerance-rel times the
reference's force at that tick (a force JND is a share of the force felt then). A candidate is
accepted when its force error exceeds its tick's tolerance on at most --tolerance-share of the
ticks and on none by more than 3 tolerances, its per-tick step exceeds the reference's by at
most its tick's tolerance, and its tick p99 is within --tick-budget of the period. The cheapest accepted is chosen: among those whose
median tick is within 10 % of the fastest, the least memory, then the smallest error; the table
says why each other candidate was rejected. Exit status 3 when even the reference is too slow. docs/tuning.md explains the
tolerance and its sources.
Writes, with --out FILE: FILE (TOML: scene, tool, model, scheme, storage, rate - read by
palpd --config and palp run --config), FILE's name with .csv (every candidate) and .png (the
chart: tick time against force error, the reference and the chosen point; drawn by palpchart).
Options:
)";

constexpr const char* kTuneOptions =
    R"(  --tool TOOL             finger:N, twofinger:N or probe:NXxNY (required): the reference; the
                          candidates have as many contact points or fewer
  --rate HZ               the loop rate to tune for, 100..100000 (required)
  --out FILE              write the chosen configuration (and FILE.csv, FILE.png)
  --param NAME=VALUE      force parameter override, repeatable (as in palp run)
  --tolerance-rel R       force error allowed at a tick, share of the reference's force there
                          (0.07)
  --tolerance-n N         force error allowed at a tick at least, N (0.035)
  --tolerance-share S     share of the ticks that may exceed their tolerance (0.01)
  --tick-budget R         tick p99 at most this share of the loop period (0.25)
  --repeats N             timing repeats per candidate, medians used (5; 1..50)
  -q, --quiet             print only the chosen configuration's line
  -h, --help              show this help
)";

double ranged(const Args& args, const std::string& key, double fallback, double lo, double hi) {
  const double v = args.number(key, fallback);
  if (!(v >= lo && v <= hi)) {
    char text[160];
    std::snprintf(text, sizeof text, "--%s must be between %g and %g", key.c_str(), lo, hi);
    throw UsageError(text);
  }
  return v;
}

std::string label(const tune::Candidate& c) {
  return c.tool + " " + to_string(c.sampler.gradient) + " " + to_string(c.sampler.storage);
}

std::string verdict_group(const tune::Judged& j) {
  if (j.reference) return "reference";
  if (j.accepted) return "accepted";
  return j.reason.rfind("too slow", 0) == 0 ? "rejected: too slow" : "rejected: force error";
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  return text;
}

std::string toml_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// palpchart next to this program (installed side by side) or in the build tree, else on PATH.
std::string find_palpchart() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    for (const fs::path& p : {self.parent_path() / "palpchart",
                              self.parent_path().parent_path() / "client" / "palpchart"})
      if (fs::exists(p, ec)) return p.string();
  }
  return "palpchart";
}

// Runs a program with arguments (no shell); its exit status, or -1 when it could not start.
int run_program(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) return -1;
  if (pid == 0) {
    execvp(args[0], args.data());
    _exit(127);
  }
  int status = 0;
  if (waitpid(pid, &status, 0) < 0) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The run in one line: what was compared and the tolerance applied.
std::string heading(const std::string& scene, const tune::Setup& setup, const tune::Outcome& o) {
  char text[640];
  std::snprintf(text, sizeof text,
                "palp tune --scene %s --tool %s --rate %g: %zu candidates, %zu ticks each on %zu "
                "paths; tolerance at each tick %g %% of the reference's force there, at least "
                "%.3f N, exceeded on at most %g %% of ticks (reference RMS force %.3f N, below "
                "%.3f N on %.0f %% of ticks); tick budget %.1f us",
                scene.c_str(), setup.tool.c_str(), setup.rate_hz, o.results.size(), o.ticks,
                o.trajectories.size(), 100.0 * setup.tolerance.rel, setup.tolerance.abs_n,
                100.0 * setup.tolerance.beyond_share, o.reference_rms_force_n,
                setup.tolerance.rel > 0 ? setup.tolerance.abs_n / setup.tolerance.rel : 0.0,
                100.0 * o.light_share, setup.tolerance.tick_budget * o.period_us);
  return text;
}

void progress_line(const tune::Judged& j, std::size_t index, std::size_t count) {
  std::fprintf(stderr,
               "palp tune: %2zu/%zu %-40s tick %6.2f us, RMS error %.4f N, beyond tolerance on "
               "%.2f %% of ticks\n",
               index + 1, count, label(j.candidate).c_str(), j.measured.tick_p50_us,
               j.measured.rms_error_n, 100.0 * j.measured.beyond_share);
}

// The chosen configuration as TOML (palpd --config, palp run/bench --config), its justification
// as comments.
void write_config(const fs::path& path, const std::string& head, const std::string& scene,
                  const tune::Setup& setup, const std::vector<std::string>& assignments,
                  const tune::Outcome& o) {
  const tune::Judged& chosen = o.results[o.chosen];
  std::ofstream f(path);
  if (!f) throw ResourceError("tune: cannot write " + path.string());
  f << "# " << head << "\n# on " << utc_now() << ", " << tune::machine_class() << "\n";
  f << "# chosen: " << label(chosen.candidate) << ": tick p50 " << chosen.measured.tick_p50_us
    << " us, p99 " << chosen.measured.tick_p99_us << " us; force error beyond its tick's "
    << "tolerance on " << 100.0 * chosen.measured.beyond_share << " % of ticks, at worst "
    << chosen.measured.worst_ratio << " tolerances; RMS " << chosen.measured.rms_error_n
    << " N, largest " << chosen.measured.max_error_n << " N\n";
  for (const tune::Judged& j : o.results)
    if (!j.accepted && j.measured.tick_p50_us < chosen.measured.tick_p50_us)
      f << "# cheaper, rejected: " << label(j.candidate) << ": " << j.reason << "\n";
  f << "scene = " << toml_string(scene) << "\n";
  f << "tool = " << toml_string(chosen.candidate.tool) << "\n";
  f << "model = " << toml_string(to_string(setup.params.model)) << "\n";
  f << "scheme = " << toml_string(to_string(chosen.candidate.sampler.gradient)) << "\n";
  f << "storage = " << toml_string(to_string(chosen.candidate.sampler.storage)) << "\n";
  f << "rate = " << setup.rate_hz << "\n";
  if (!assignments.empty()) {
    f << "param = [";
    for (std::size_t i = 0; i < assignments.size(); ++i)
      f << (i ? ", " : "") << toml_string(assignments[i]);
    f << "]\n";
  }
  if (!f) throw ResourceError("tune: cannot write " + path.string());
}

// Every candidate's figures as CSV.
void write_csv(const fs::path& path, const tune::Outcome& o) {
  std::ofstream f(path);
  f << "candidate,tool,scheme,storage,tick_p50_us,tick_p99_us,rms_error_n,max_error_n,"
       "lateral_rms_error_n,step_excess_n,beyond_share,worst_ratio,step_ratio,map_mib,verdict,"
       "chosen,reason\n";
  for (const tune::Judged& j : o.results) {
    const tune::Measured& m = j.measured;
    f << label(j.candidate) << ',' << j.candidate.tool << ','
      << to_string(j.candidate.sampler.gradient) << ',' << to_string(j.candidate.sampler.storage)
      << ',' << m.tick_p50_us << ',' << m.tick_p99_us << ',' << m.rms_error_n << ','
      << m.max_error_n << ',' << m.lateral_rms_error_n << ',' << m.step_excess_n << ','
      << m.beyond_share << ',' << m.worst_ratio << ',' << m.step_ratio << ','
      << static_cast<double>(m.map_bytes) / 1048576.0 << ',' << verdict_group(j) << ','
      << (j.chosen ? 1 : 0) << ",\"" << j.reason << "\"\n";
  }
  if (!f) throw ResourceError("tune: cannot write " + path.string());
}

// The chart of the CSV (palpchart): its exit status, -1 when it could not start.
int draw_chart(const fs::path& csv, const fs::path& png, const std::string& scene,
               const tune::Setup& setup) {
  char title[256];
  std::snprintf(title, sizeof title, "palp tune: %s, %s at %g Hz (tolerance %g %% per tick)",
                fs::path(scene).filename().string().c_str(), setup.tool.c_str(), setup.rate_hz,
                100.0 * setup.tolerance.rel);
  return run_program({find_palpchart(),
                      "--csv",
                      csv.string(),
                      "--x",
                      "tick_p50_us",
                      "--y",
                      "rms_error_n",
                      "--group",
                      "verdict",
                      "--mark",
                      "chosen",
                      "--mark-label",
                      "chosen",
                      "--style",
                      "points",
                      "--xlabel",
                      "tick time, median (us)",
                      "--ylabel",
                      "RMS force error against the reference (N)",
                      "--title",
                      title,
                      "--legend",
                      "tr",
                      "--size",
                      "1000x640",
                      "--out",
                      png.string()});
}

// Every candidate, one line each, after the heading.
void print_table(const std::string& head, const tune::Outcome& o) {
  std::printf("%s\n", head.c_str());
  std::printf("  %-36s %8s %8s %9s %9s %8s %7s %7s %8s  %s\n", "candidate", "p50 us", "p99 us",
              "RMS err N", "max err N", "beyond %", "worst x", "step x", "maps MiB", "verdict");
  for (const tune::Judged& j : o.results) {
    const tune::Measured& m = j.measured;
    std::printf("%c %-36s %8.2f %8.2f %9.4f %9.4f %8.2f %7.2f %7.2f %8.1f  %s%s\n",
                j.chosen ? '*' : ' ', label(j.candidate).c_str(), m.tick_p50_us, m.tick_p99_us,
                m.rms_error_n, m.max_error_n, 100.0 * m.beyond_share, m.worst_ratio, m.step_ratio,
                static_cast<double>(m.map_bytes) / 1048576.0, j.reference ? "reference, " : "",
                j.reason.c_str());
  }
}

}  // namespace

int cmd_tune(const Arguments& argv_in) {
  Arguments argv = argv_in;
  const std::vector<std::string> assignments = take_repeated(argv, "param");
  std::vector<std::string> valued = kSceneOptions;
  valued.insert(valued.end(), {"tool", "rate", "out", "tolerance-rel", "tolerance-n",
                               "tolerance-share", "tick-budget", "repeats"});
  const Args args(argv, {"help", "quiet"}, valued);
  if (args.has("help")) {
    std::cout << kTuneUsage << kSceneOptionsHelp << kTuneOptions;
    return 0;
  }
  if (!args.positional().empty())
    throw UsageError("tune takes no positional arguments (got '" + args.positional().front() +
                     "')");
  const auto tool_spec = args.get("tool");
  if (!tool_spec) throw UsageError("tune needs --tool TOOL");
  if (!args.get("rate")) throw UsageError("tune needs --rate HZ (the loop rate to tune for)");
  const bool quiet = args.has("quiet");

  tune::Setup setup;
  setup.tool = *tool_spec;
  const Tool tool = parse_tool(setup.tool);
  setup.rate_hz = ranged(args, "rate", 1000.0, 100.0, 100000.0);
  setup.params = force_params(model_kind(args), tool, assignments);
  setup.tolerance.rel = ranged(args, "tolerance-rel", setup.tolerance.rel, 0.0, 1.0);
  setup.tolerance.abs_n = ranged(args, "tolerance-n", setup.tolerance.abs_n, 0.0, 10.0);
  setup.tolerance.beyond_share =
      ranged(args, "tolerance-share", setup.tolerance.beyond_share, 0.0, 0.5);
  setup.tolerance.tick_budget = ranged(args, "tick-budget", setup.tolerance.tick_budget, 0.01, 1.0);
  const double repeats = ranged(args, "repeats", 5, 1, 50);
  if (repeats != std::floor(repeats)) throw UsageError("--repeats needs a whole number");
  setup.repeats = static_cast<int>(repeats);
  const auto out = args.get("out");

  const auto start = std::chrono::steady_clock::now();
  const Scene scene = load_scene_for(args, "tune", quiet);
  const SceneMaps maps = read_scene_maps(scene);  // as the scene's sampler has them
  const tune::Outcome o = tune::tune(maps.surf, maps.bone, setup, quiet ? nullptr : progress_line);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const tune::Judged& chosen = o.results[o.chosen];

  const std::string head = heading(scene.source, setup, o);
  if (!quiet) print_table(head, o);
  const tune::Measured& ref = o.results.front().measured;
  std::printf(
      "chosen: %s (tick p50 %.2f us vs the reference's %.2f us, %.1fx; force error beyond "
      "its tick's tolerance on %.2f %% of ticks, at worst %.2f tolerances; RMS %.4f N)%s; "
      "%.1f s\n",
      label(chosen.candidate).c_str(), chosen.measured.tick_p50_us, ref.tick_p50_us,
      chosen.measured.tick_p50_us > 0.0 ? ref.tick_p50_us / chosen.measured.tick_p50_us : 0.0,
      100.0 * chosen.measured.beyond_share, chosen.measured.worst_ratio,
      chosen.measured.rms_error_n,
      chosen.accepted ? "" : " - NOTHING passes: even the reference is too slow at this rate",
      seconds);
  if (!out) return chosen.accepted ? 0 : 3;

  const fs::path out_path(*out);
  if (out_path.has_parent_path()) fs::create_directories(out_path.parent_path());
  write_config(out_path, head, scene.source, setup, assignments, o);
  fs::path csv = out_path, png = out_path;
  csv.replace_extension(".csv");
  png.replace_extension(".png");
  write_csv(csv, o);
  const int rc = draw_chart(csv, png, scene.source, setup);
  if (!quiet) {
    std::printf("wrote %s, %s", out_path.string().c_str(), csv.string().c_str());
    if (rc == 0)
      std::printf(", %s\n", png.string().c_str());
    else
      std::printf("; no chart (palpchart did not run: exit %d)\n", rc);
  }
  return chosen.accepted ? 0 : 3;
}

}  // namespace palp::cli
