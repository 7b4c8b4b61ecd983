// prep_cases: the whole prep (run_prep, default parameters, no cache) on every case of issue 38,
// scored against truth: the torso phantom as real scans vary it (contrast phase, aorta HU, thin
// slabs and where they lie, 5 mm slices, both arms with their brachial arteries on the humerus,
// a metal implant, a dissected aorta; common/io/phantom.hpp) and, when ../shared/data has them,
// the real CTs with their labels. One Markdown table on stdout: case, structure, Dice, ASSD mm,
// then the case's further figure with its goal and whether it is met; progress on stderr. It
// measures; it is not a test (tests/bench/prep_cases.sh builds and runs it).
//
// Figures and goals (issue 38; the phantoms' vessel goals are the real aorta case's):
//   bone              Dice and ASSD against the truth bone (phantom) or the expert labels (value 2)
//   vessel            prep's vessel.nii.gz against the truth vessel (contrast-filled lumens):
//                     Dice, ASSD and coverage (share of truth-vessel voxels in the mask) >= 0.9;
//                     "—" while prep writes no vessel mask
//   truth vessel      % of it inside prep's bone <= 5
//   vessel / body     vessel voxels as % of the body where the scan has no contrast <= 1
//   contrast_phase    prep.json's, against the phase drawn
//   aorta, branches   % inside prep's bone <= 5 and <= 10; aorta coverage by the vessel mask >= 0.9
//   T12               recall of the labelled vertebra in prep's bone >= 0.9
//
// Usage: prep_cases [--only TEXT] [--keep DIR] [--shared-data DIR] [--vessels auto|off]
//   --vessels off       prep without its vessel search (default auto, as palp prep)
//   --only TEXT         run only the cases whose name contains TEXT
//   --keep DIR          write each case's prep (and a phantom's truth_bone.nii.gz and
//                       truth_vessel.nii.gz) into DIR/<n> and keep it (default: a temporary
//                       directory, removed at the end)
//   --shared-data DIR   the real CTs (default: $PALP_SHARED_DATA_DIR, else ../shared/data)
#include <unistd.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "prep/prep.hpp"
#include "support/mask_metrics.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::count;
using testing::count_both;

constexpr const char* kNone = "—";

// ---------------------------------------------------------------------------------------------
// The table

struct Goal {
  enum Kind { kNoGoal, kAtLeast, kAtMost, kEqual } kind = kNoGoal;
  double value = 0.0;
  std::string text;  // for kEqual

  std::string describe() const {
    char buf[64];
    switch (kind) {
      case kAtLeast:
        std::snprintf(buf, sizeof buf, "≥ %g", value);
        return buf;
      case kAtMost:
        std::snprintf(buf, sizeof buf, "≤ %g", value);
        return buf;
      case kEqual:
        return text;
      case kNoGoal:
        break;
    }
    return kNone;
  }
  std::optional<bool> met(std::optional<double> v) const {
    if (!v || kind == kNoGoal || kind == kEqual) return std::nullopt;
    return kind == kAtLeast ? *v >= value : *v <= value;
  }
};

Goal at_least(double v) {
  return {Goal::kAtLeast, v, ""};
}
Goal at_most(double v) {
  return {Goal::kAtMost, v, ""};
}

struct Row {
  Row(std::string c, std::string s) : case_name(std::move(c)), structure(std::move(s)) {}
  std::string case_name, structure;
  std::optional<double> dice, assd_mm;
  std::string figure = kNone, value = kNone, goal = kNone, met = kNone;
};

std::string fmt(std::optional<double> v, const char* format) {
  if (!v || !std::isfinite(*v)) return kNone;
  char buf[64];
  std::snprintf(buf, sizeof buf, format, *v);
  return buf;
}

std::string yes_no(std::optional<bool> b) {
  return b ? (*b ? "yes" : "**no**") : kNone;
}

// A figure with its goal: `value` empty when it cannot be measured (`why` says why).
Row figure_row(const std::string& case_name, const std::string& structure,
               const std::string& figure, std::optional<double> value, const char* format,
               const Goal& goal, const std::string& why = kNone) {
  Row r{case_name, structure};
  r.figure = figure;
  r.value = value ? fmt(value, format) : why;
  r.goal = goal.describe();
  r.met = yes_no(goal.met(value));
  return r;
}

void print_table(const std::vector<Row>& rows) {
  std::printf("| case | structure | Dice | ASSD mm | figure | value | goal | met |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (const Row& r : rows) {
    std::printf("| %s | %s | %s | %s | %s | %s | %s | %s |\n", r.case_name.c_str(),
                r.structure.c_str(), fmt(r.dice, "%.3f").c_str(), fmt(r.assd_mm, "%.2f").c_str(),
                r.figure.c_str(), r.value.c_str(), r.goal.c_str(), r.met.c_str());
  }
}

// ---------------------------------------------------------------------------------------------
// Prep and its outputs

struct PrepOutputs {
  Mask bone, body;
  std::optional<Mask> vessel;
  std::string contrast_phase;  // empty when prep.json has none
  double seconds = 0.0;
};

std::string json_string_field(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\"");
  if (at == std::string::npos) return "";
  const std::size_t colon = json.find(':', at);
  const std::size_t open = json.find('"', colon);
  const std::size_t close = open == std::string::npos ? open : json.find('"', open + 1);
  if (colon == std::string::npos || close == std::string::npos) return "";
  return json.substr(open + 1, close - open - 1);
}

// --vessels off: prep does not look for contrast-filled lumens (on by default, as palp prep).
bool g_find_vessels = true;

PrepOutputs run_and_read(const std::string& input, const fs::path& dir) {
  PrepParams params;
  params.use_cache = false;
  params.find_vessels = g_find_vessels;
  const auto start = std::chrono::steady_clock::now();
  run_prep(input, dir.string(), params);
  PrepOutputs out;
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.bone = read_nifti_mask((dir / kBoneFile).string());
  out.body = read_nifti_mask((dir / kBodyFile).string());
  if (fs::exists(dir / "vessel.nii.gz"))
    out.vessel = read_nifti_mask((dir / "vessel.nii.gz").string());
  std::ifstream json(dir / kPrepJsonFile);
  const std::string text((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  out.contrast_phase = json_string_field(text, "contrast_phase");
  return out;
}

// Share (0-1) of `part`'s voxels inside `whole`; none for an empty `part`.
std::optional<double> share_inside(const Mask& part, const Mask& whole) {
  const std::int64_t n = count(part);
  if (n == 0) return std::nullopt;
  return static_cast<double>(count_both(part, whole)) / static_cast<double>(n);
}

std::optional<double> percent(std::optional<double> share) {
  if (!share) return std::nullopt;
  return 100.0 * *share;
}

// Dice and ASSD of `mask` against `truth`; none where either is empty.
Row overlap_row(const std::string& case_name, const std::string& structure, const Mask& mask,
                const Mask& truth) {
  Row r{case_name, structure};
  if (count(mask) > 0 && count(truth) > 0) {
    r.dice = testing::dice(mask, truth);
    r.assd_mm = testing::mean_surface_distance(mask, truth);
  } else if (count(truth) > 0) {
    r.dice = 0.0;
  }
  return r;
}

bool same_grid(const Mask& a, const Mask& b) {
  return a.grid.dims == b.grid.dims;
}

// contrast_phase found against the one drawn (empty: not known).
Row phase_row(const std::string& case_name, const std::string& found, const std::string& drawn) {
  Row r{case_name, "contrast_phase"};
  r.figure = drawn.empty() ? "found" : "found (drawn " + drawn + ")";
  r.value = found.empty() ? std::string(kNone) + " (not in prep.json)" : found;
  if (!drawn.empty()) {
    r.goal = "= " + drawn;
    r.met = found.empty() ? kNone : yes_no(found == drawn);
  }
  return r;
}

// The vessel mask's coverage of `truth` (with Dice and ASSD), or "—" without a mask.
Row vessel_row(const std::string& case_name, const std::string& structure,
               const std::optional<Mask>& vessel, const Mask& truth, bool with_overlap) {
  const std::string figure = "coverage of " + structure;
  if (!vessel) {
    return figure_row(case_name, "vessel", figure, std::nullopt, "", at_least(0.9),
                      std::string(kNone) + " (no vessel mask)");
  }
  Row r =
      figure_row(case_name, "vessel", figure, share_inside(truth, *vessel), "%.3f", at_least(0.9));
  if (with_overlap) {
    const Row o = overlap_row(case_name, "vessel", *vessel, truth);
    r.dice = o.dice;
    r.assd_mm = o.assd_mm;
  }
  return r;
}

// Vessel voxels as % of the body, where the scan shows no contrast-filled vessel.
Row vessel_share_row(const std::string& case_name, const std::optional<Mask>& vessel,
                     const Mask& body) {
  std::optional<double> pct;
  if (vessel)
    pct = 100.0 * static_cast<double>(count_both(*vessel, body)) / static_cast<double>(count(body));
  return figure_row(case_name, "vessel", "% of body", pct, "%.2f", at_most(1.0),
                    std::string(kNone) + " (no vessel mask)");
}

// ---------------------------------------------------------------------------------------------
// The cases

struct PhantomCase {
  std::string name;
  std::string spec;   // after "phantom:"
  std::string drawn;  // the contrast phase drawn
};

std::vector<PhantomCase> phantom_cases() {
  const std::string slab = "torso,dims=384x256x20,spacing=1.25x1.25x1.5";
  return {
      {"torso (default: aorta 250 alone)", "torso", "arterial"},
      {"contrast none", "torso,contrast=none", "none"},
      {"contrast arterial", "torso,contrast=arterial", "arterial"},
      {"contrast portal-venous", "torso,contrast=portal-venous", "portal-venous"},
      {"aorta 150 HU", "torso,aorta-hu=150", "arterial"},
      {"aorta 250 HU", "torso,aorta-hu=250", "arterial"},
      {"aorta 400 HU", "torso,aorta-hu=400", "arterial"},
      {"slab 20 x 1.5 mm", slab, "arterial"},
      {"slab 20 x 1.5 mm, aorta 400 HU", slab + ",aorta-hu=400", "arterial"},
      {"5 mm slices", "torso,dims=384x256x40,spacing=1.25x1.25x5", "arterial"},
      {"both arms", "torso,arms=2", "arterial"},
      {"metal implant", "torso,metal", "arterial"},
      {"aortic dissection (arterial)", "torso,contrast=arterial,dissection", "arterial"},
      {"aortic dissection, 5 mm slices",
       "torso,contrast=arterial,dissection,dims=384x256x40,spacing=1.25x1.25x5", "arterial"},
      {"aortic dissection, slab 20 x 1.5 mm", slab + ",contrast=arterial,dissection", "arterial"},
      {"slab 20 x 1.5 mm at z -9 mm (SMA cut off)", slab + ",contrast=arterial,level=-9",
       "arterial"},
      {"slab 20 x 1.5 mm, aorta 150 HU, both arms (as the unseen series)",
       slab + ",aorta-hu=150,arms=2", "arterial"}};
}

// With `keep` (--keep), the truth masks are written beside the prep's (truth_bone.nii.gz,
// truth_vessel.nii.gz) for looking at what a case misses.
void score_phantom(const PhantomCase& c, const PrepOutputs& p, const fs::path* keep,
                   std::vector<Row>& rows) {
  const PhantomSpec spec = parse_phantom_spec(c.spec);
  PhantomTruth truth;
  make_phantom(spec.name, spec.options, &truth);
  if (keep) {
    write_nifti((*keep / "truth_bone.nii.gz").string(), truth.bone);
    write_nifti((*keep / "truth_vessel.nii.gz").string(), truth.vessel);
  }
  if (!same_grid(p.bone, truth.bone)) throw std::runtime_error("prep's masks are off the grid");
  rows.push_back(overlap_row(c.name, "bone", p.bone, truth.bone));
  if (count(truth.vessel) > 0) {
    rows.push_back(vessel_row(c.name, "truth vessel", p.vessel, truth.vessel, true));
    rows.push_back(figure_row(c.name, "truth vessel", "% inside bone",
                              percent(share_inside(truth.vessel, p.bone)), "%.1f", at_most(5.0)));
  } else {
    rows.push_back(vessel_share_row(c.name, p.vessel, truth.body));
  }
  rows.push_back(phase_row(c.name, p.contrast_phase, c.drawn));
}

Mask label_mask(const DistanceMap& labels, float value) {
  Mask m(labels.grid, 0);
  for (std::size_t n = 0; n < labels.data.size(); ++n) m.data[n] = labels.data[n] == value;
  return m;
}

// ct_abdomen_3mm: bone against the experts' labels (2), vessel voxels as % of the body.
void score_abdomen(const std::string& name, const PrepOutputs& p, const DistanceMap& labels,
                   std::vector<Row>& rows) {
  const Mask truth_bone = label_mask(labels, 2.0f);
  if (!same_grid(p.bone, truth_bone)) throw std::runtime_error("labels are off prep's grid");
  rows.push_back(overlap_row(name, "bone (labels 2)", p.bone, truth_bone));
  rows.push_back(vessel_share_row(name, p.vessel, p.body));
  rows.push_back(phase_row(name, p.contrast_phase, ""));
}

// ct_aorta_contrast_1.5mm: vessels are not bone, T12 is, the vessel mask covers the aorta.
void score_aorta(const std::string& name, const PrepOutputs& p, const DistanceMap& labels,
                 std::vector<Row>& rows) {
  const Mask aorta = label_mask(labels, 1.0f), branches = label_mask(labels, 2.0f),
             t12 = label_mask(labels, 3.0f);
  if (!same_grid(p.bone, aorta)) throw std::runtime_error("labels are off prep's grid");
  rows.push_back(figure_row(name, "aorta (labels 1)", "% inside bone",
                            percent(share_inside(aorta, p.bone)), "%.1f", at_most(5.0)));
  rows.push_back(figure_row(name, "branches (labels 2)", "% inside bone",
                            percent(share_inside(branches, p.bone)), "%.1f", at_most(10.0)));
  rows.push_back(figure_row(name, "T12 (labels 3)", "recall in bone", share_inside(t12, p.bone),
                            "%.3f", at_least(0.9)));
  rows.push_back(vessel_row(name, "aorta", p.vessel, aorta, false));
  rows.push_back(phase_row(name, p.contrast_phase, "arterial"));
}

struct RealCase {
  std::string name, ct, labels;
  std::function<void(const std::string&, const PrepOutputs&, const DistanceMap&, std::vector<Row>&)>
      score;
};

std::vector<RealCase> real_cases() {
  return {{"ct_abdomen_3mm", "ct_abdomen_3mm.nii.gz", "ct_abdomen_3mm_reference_labels.nii.gz",
           score_abdomen},
          {"ct_aorta_contrast_1.5mm", "ct_aorta_contrast_1.5mm.nii.gz",
           "ct_aorta_contrast_1.5mm_labels.nii.gz", score_aorta}};
}

// ---------------------------------------------------------------------------------------------
// main

struct Options {
  std::string only;
  std::string keep;
  std::string shared_data;
};

Options parse_options(int argc, char** argv) {
  Options o;
  const char* env = std::getenv("PALP_SHARED_DATA_DIR");
  o.shared_data = env && *env ? env : PALP_SHARED_DATA_DIR;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--only" && has_value) {
      o.only = argv[++i];
    } else if (arg == "--keep" && has_value) {
      o.keep = argv[++i];
    } else if (arg == "--shared-data" && has_value) {
      o.shared_data = argv[++i];
    } else if (arg == "--vessels" && has_value) {
      const std::string v = argv[++i];
      if (v != "auto" && v != "off") std::exit(2);
      g_find_vessels = v == "auto";
    } else {
      std::fprintf(stderr,
                   "usage: prep_cases [--only TEXT] [--keep DIR] [--shared-data DIR] "
                   "[--vessels auto|off]\n");
      std::exit(arg == "-h" || arg == "--help" ? 0 : 2);
    }
  }
  return o;
}

// Runs one case: prep into `dir`, then `score`; a failure becomes a row that says so.
void run_case(const std::string& name, const std::string& input, const fs::path& dir,
              const std::function<void(const PrepOutputs&)>& score, std::vector<Row>& rows) {
  std::fprintf(stderr, "%s: prep %s ...", name.c_str(), input.c_str());
  std::fflush(stderr);
  try {
    const PrepOutputs p = run_and_read(input, dir);
    std::fprintf(stderr, " %.1f s, scoring ...", p.seconds);
    std::fflush(stderr);
    score(p);
    std::fprintf(stderr, " done\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, " failed: %s\n", e.what());
    Row r{name, "—"};
    r.figure = "prep or scoring failed";
    r.value = e.what();
    rows.push_back(r);
  }
}

int run(const Options& o) {
  const fs::path work =
      o.keep.empty() ? fs::temp_directory_path() / ("palp_prep_cases_" + std::to_string(::getpid()))
                     : fs::path(o.keep);
  fs::create_directories(work);
  std::vector<Row> rows;
  int n = 0;
  for (const PhantomCase& c : phantom_cases()) {
    ++n;
    if (c.name.find(o.only) == std::string::npos) continue;
    const fs::path dir = work / std::to_string(n);
    run_case(
        c.name, "phantom:" + c.spec, dir,
        [&](const PrepOutputs& p) { score_phantom(c, p, o.keep.empty() ? nullptr : &dir, rows); },
        rows);
  }
  for (const RealCase& c : real_cases()) {
    ++n;
    if (c.name.find(o.only) == std::string::npos) continue;
    const fs::path ct = fs::path(o.shared_data) / c.ct, labels = fs::path(o.shared_data) / c.labels;
    if (!fs::exists(ct) || !fs::exists(labels)) {
      std::fprintf(stderr, "%s: skipped (%s or its labels absent)\n", c.name.c_str(),
                   ct.string().c_str());
      continue;
    }
    run_case(
        c.name, ct.string(), work / std::to_string(n),
        [&](const PrepOutputs& p) { c.score(c.name, p, read_nifti_float(labels), rows); }, rows);
  }
  print_table(rows);
  if (o.keep.empty()) fs::remove_all(work);
  return 0;
}

}  // namespace
}  // namespace palp

int main(int argc, char** argv) {
  return palp::run(palp::parse_options(argc, argv));
}
