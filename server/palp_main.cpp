// palp — the offline command-line tool: synthetic phantoms and CT preprocessing.
//   palp phantom NAME --out FILE        synthetic CT in HU (cube, sphere, torso)
//   palp prep INPUT --out DIR           masks and signed distance maps (spec "Files")
// Errors print one line on stderr and exit non-zero: 1 for failures, 2 for usage mistakes.
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <iostream>
#include <map>
#include <new>
#include <optional>
#include <string>
#include <vector>

#include "ct_io.hpp"
#include "errors.hpp"
#include "parallel.hpp"
#include "phantom.hpp"
#include "prep.hpp"

namespace palp {
namespace {

constexpr const char* kMainUsage = R"(usage: palp <command> [options]

Commands:
  phantom NAME --out FILE   write a synthetic CT in HU (cube, sphere, torso)
  prep INPUT --out DIR      CT -> body and bone masks and signed distance maps
  version                   print the version

Run `palp <command> --help` for the options of a command.
)";

constexpr const char* kPhantomUsage = R"(usage: palp phantom NAME --out FILE [options]

Writes a synthetic CT in Hounsfield units as NIfTI (.nii or .nii.gz).
  NAME                  cube    soft-tissue block (90 mm a side, flat faces, no bone), 1 mm grid
                        sphere  soft-tissue ball of analytic radius, 1 mm grid
                        torso   the default scene: body, ribs, liver, spine, lungs, bowel gas,
                                an arm and a CT table with pad and cable
Options:
  --out FILE            output file (required)
  --dims NXxNYxNZ       grid size in voxels (default: the phantom's own)
  --spacing SXxSYxSZ    voxel size in mm (default: the phantom's own)
  -h, --help            show this help
)";

constexpr const char* kPrepUsage = R"(usage: palp prep INPUT --out DIR [options]

Segments body and bone and computes the signed distance maps the force model samples.
INPUT: a .nii/.nii.gz/.mha/.mhd/.nrrd/.nhdr file, a DICOM series directory, or phantom:NAME.
Writes body.nii.gz, bone.nii.gz, d_surf.nii.gz, d_bone.nii.gz and prep.json into DIR.
Options:
  --out DIR               output directory (required; created if missing)
  --no-cache              recompute even if DIR already holds the result for this input
  --band MM               clamp |distance| beyond this many mm (default 60)
  --threads N             worker threads (default: all cores)
  --body-threshold HU     voxels above this are not air (default -500)
  --min-body-part ML      drop separate parts smaller than this (default 50)
  --bone-seed HU          bone region-growing seeds at or above (default 300)
  --bone-grow HU          bone grows into voxels at or above (default 180)
  --min-bone-island ML    drop bone islands smaller than this (default 0.5)
  -q, --quiet             print only errors
  -h, --help              show this help
)";

// A small option parser: positional arguments, "--flag" and "--key VALUE" (or --key=VALUE).
class Args {
 public:
  Args(std::vector<std::string> argv, std::vector<std::string> flags,
       std::vector<std::string> valued)
      : flags_(std::move(flags)), valued_(std::move(valued)) {
    for (std::size_t i = 0; i < argv.size(); ++i) {
      std::string arg = argv[i];
      if (arg == "-h") arg = "--help";
      if (arg == "-q") arg = "--quiet";
      if (arg.rfind("--", 0) != 0 || arg == "--") {
        positional_.push_back(arg);
        continue;
      }
      std::string key = arg.substr(2), value;
      const auto eq = key.find('=');
      const bool inline_value = eq != std::string::npos;
      if (inline_value) {
        value = key.substr(eq + 1);
        key = key.substr(0, eq);
      }
      if (contains(flags_, key) && !inline_value) {
        options_.insert_or_assign(key, std::string());  // a flag: present, no value
      } else if (contains(valued_, key)) {
        if (!inline_value) {
          if (i + 1 >= argv.size()) throw UsageError("option --" + key + " needs a value");
          value = argv[++i];
        }
        options_[key] = value;
      } else {
        throw UsageError("unknown option --" + key);
      }
    }
  }
  bool has(const std::string& key) const { return options_.count(key) != 0; }
  std::optional<std::string> get(const std::string& key) const {
    const auto it = options_.find(key);
    if (it == options_.end()) return std::nullopt;
    return it->second;
  }
  const std::vector<std::string>& positional() const { return positional_; }

  double number(const std::string& key, double fallback) const {
    const auto text = get(key);
    if (!text) return fallback;
    double value = 0;
    const auto [end, ec] = std::from_chars(text->data(), text->data() + text->size(), value);
    if (ec != std::errc() || end != text->data() + text->size() || !std::isfinite(value)) {
      throw UsageError("--" + key + " needs a number, got '" + *text + "'");
    }
    return value;
  }

 private:
  static bool contains(const std::vector<std::string>& list, const std::string& key) {
    return std::find(list.begin(), list.end(), key) != list.end();
  }
  std::vector<std::string> flags_, valued_;
  std::map<std::string, std::string> options_;
  std::vector<std::string> positional_;
};

// Parses "AxBxC" into three numbers.
template <class T>
std::array<T, 3> parse_triple(const std::string& text, const std::string& option) {
  std::array<T, 3> out{};
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int a = 0; a < 3; ++a) {
    const auto [next, ec] = std::from_chars(p, end, out[a]);
    if (ec != std::errc() || next == p) {
      throw UsageError("--" + option + " needs NXxNYxNZ, got '" + text + "'");
    }
    p = next;
    if (a < 2) {
      if (p == end || (*p != 'x' && *p != 'X')) {
        throw UsageError("--" + option + " needs NXxNYxNZ, got '" + text + "'");
      }
      ++p;
    }
  }
  if (p != end) throw UsageError("--" + option + " needs NXxNYxNZ, got '" + text + "'");
  return out;
}

std::string format_triple(const Vec3& v) {
  char text[96];
  std::snprintf(text, sizeof text, "%g x %g x %g", v[0], v[1], v[2]);
  return text;
}

int cmd_phantom(const std::vector<std::string>& argv) {
  const Args args(argv, {"help"}, {"out", "dims", "spacing"});
  if (args.has("help")) {
    std::cout << kPhantomUsage;
    return 0;
  }
  if (args.positional().size() != 1) throw UsageError("phantom needs one NAME (cube, sphere, torso)");
  const auto out = args.get("out");
  if (!out) throw UsageError("phantom needs --out FILE");
  PhantomOptions options;
  if (const auto dims = args.get("dims")) options.dims = parse_triple<std::int64_t>(*dims, "dims");
  if (const auto spacing = args.get("spacing")) options.spacing = parse_triple<double>(*spacing, "spacing");
  const CtVolume ct = make_phantom(args.positional()[0], options);
  write_nifti(*out, ct);
  const Index3& d = ct.grid.dims;
  std::printf("wrote %s: %s phantom, %lld x %lld x %lld voxels of %s mm\n", out->c_str(),
              args.positional()[0].c_str(), static_cast<long long>(d[0]),
              static_cast<long long>(d[1]), static_cast<long long>(d[2]),
              format_triple(ct.grid.spacing).c_str());
  return 0;
}

int cmd_prep(const std::vector<std::string>& argv) {
  const Args args(argv, {"help", "no-cache", "quiet"},
                  {"out", "band", "threads", "body-threshold", "min-body-part", "bone-seed",
                   "bone-grow", "min-bone-island"});
  if (args.has("help")) {
    std::cout << kPrepUsage;
    return 0;
  }
  if (args.positional().size() != 1) throw UsageError("prep needs one INPUT");
  const auto out = args.get("out");
  if (!out) throw UsageError("prep needs --out DIR");
  PrepParams params;
  params.use_cache = !args.has("no-cache");
  SegmentationParams& seg = params.segmentation;
  seg.body_threshold_hu = args.number("body-threshold", seg.body_threshold_hu);
  seg.min_body_part_ml = args.number("min-body-part", seg.min_body_part_ml);
  seg.bone_seed_hu = args.number("bone-seed", seg.bone_seed_hu);
  seg.bone_grow_hu = args.number("bone-grow", seg.bone_grow_hu);
  seg.min_bone_island_ml = args.number("min-bone-island", seg.min_bone_island_ml);
  params.distance.band_mm = args.number("band", params.distance.band_mm);
  const double threads = args.number("threads", default_thread_count());
  if (threads < 1 || threads > 1024 || threads != static_cast<unsigned>(threads)) {
    throw UsageError("--threads needs a whole number from 1 to 1024");
  }
  params.distance.threads = static_cast<unsigned>(threads);
  if (seg.bone_grow_hu > seg.bone_seed_hu) {
    throw UsageError("--bone-grow must not exceed --bone-seed");
  }
  const bool quiet = args.has("quiet");

  const std::string& input = args.positional()[0];
  if (!quiet) std::fprintf(stderr, "palp prep: %s -> %s\n", input.c_str(), out->c_str());
  PrepProgress progress;
  if (!quiet) {
    progress = [](const std::string& stage, bool finished, double seconds) {
      if (!finished) {
        std::fprintf(stderr, "  %-14s ...", stage.c_str());
      } else {
        std::fprintf(stderr, " %7.3f s\n", seconds);
      }
      std::fflush(stderr);
    };
  }
  const PrepResult r = run_prep(input, *out, params, progress);
  if (quiet) return 0;
  const Index3& d = r.grid.dims;
  const double voxel_ml = r.grid.spacing[0] * r.grid.spacing[1] * r.grid.spacing[2] / 1000.0;
  std::printf("prep %s%s\n", r.out_dir.c_str(), r.from_cache ? " (cached: input and parameters unchanged)" : "");
  std::printf("  grid      %lld x %lld x %lld voxels of %s mm\n", static_cast<long long>(d[0]),
              static_cast<long long>(d[1]), static_cast<long long>(d[2]),
              format_triple(r.grid.spacing).c_str());
  std::printf("  body      %llu voxels (%.0f ml)\n", static_cast<unsigned long long>(r.stats.body_voxels),
              static_cast<double>(r.stats.body_voxels) * voxel_ml);
  std::printf("  bone      %llu voxels (%.0f ml)\n", static_cast<unsigned long long>(r.stats.bone_voxels),
              static_cast<double>(r.stats.bone_voxels) * voxel_ml);
  if (!r.from_cache) {
    std::printf("  removed   %llu voxels that are not the patient (table, pad, cables)\n",
                static_cast<unsigned long long>(r.stats.removed_non_patient_voxels));
  }
  std::printf("  total     %.3f s, peak memory %.0f MiB, %u threads\n", r.total_seconds,
              static_cast<double>(r.peak_rss_bytes) / 1048576.0, params.distance.threads);
  return 0;
}

int dispatch(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kMainUsage;
    return 2;
  }
  const std::string command = argv[1];
  const std::vector<std::string> rest(argv + 2, argv + argc);
  if (command == "-h" || command == "--help" || command == "help") {
    std::cout << kMainUsage;
    return 0;
  }
  if (command == "version" || command == "--version") {
    std::cout << "palp " << PALP_VERSION << '\n';
    return 0;
  }
  const std::map<std::string, std::function<int(const std::vector<std::string>&)>> commands = {
      {"phantom", cmd_phantom}, {"prep", cmd_prep}};
  const auto it = commands.find(command);
  if (it == commands.end()) throw UsageError("unknown command '" + command + "' (try palp --help)");
  return it->second(rest);
}

}  // namespace
}  // namespace palp

int main(int argc, char** argv) {
  try {
    return palp::dispatch(argc, argv);
  } catch (const palp::UsageError& e) {
    std::fprintf(stderr, "palp: %s\n", e.what());
    return 2;
  } catch (const palp::Error& e) {
    std::fprintf(stderr, "palp: error: %s\n", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "palp: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "palp: error: %s\n", e.what());
    return 1;
  }
}
