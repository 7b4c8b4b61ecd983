// The bone mask (common/prep/bone/bone_segmentation.cpp) on the shared CT changed the ways other
// scanners and protocols differ from it — calibration, noise, thicker slices, contrast in the
// organs, a shorter scan, another storage order — each scored against the expert labels carried
// through the same change (support/shared_ct_labels.hpp). Issue 13 asks for a method that holds
// on series it has never seen; one labelled CT cannot show that, but it can show what each of
// these differences costs. Skips when the data is absent. Figures: docs/prep.md, "The shared CT
// changed as other protocols change it".
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "prep/reorient.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/hu_levels.hpp"
#include "prep/segment/segmentation.hpp"
#include "support/shared_ct_labels.hpp"
#include "support/torso_scenes.hpp"

namespace palp {
namespace {

using testing::BoneScore;
using testing::LabelledCt;

// A CT with the labels that go with it: the change applied to both.
struct Case {
  std::string name;
  LabelledCt d;
};

struct Result {
  BoneScore score;
  HuLevels levels;
  Mask bone;
};

// The body and bone masks as prep makes them (levels moved with the scan's soft-tissue peak), or
// with the levels moved by `forced_offset_hu` instead when it is given.
Result segment_as_prep(const CtVolume& ct, const Mask& truth_bone, const Mask& organs,
                       const double* forced_offset_hu = nullptr) {
  Result r;
  const Mask body = segment_body(ct, SegmentationParams{});
  r.levels = estimate_hu_levels(ct, body);
  if (forced_offset_hu) r.levels.offset_hu = *forced_offset_hu;
  SegmentationParams params;
  params.bone_seed_hu += r.levels.offset_hu;
  params.bone_grow_hu += r.levels.offset_hu;
  r.bone = segment_bone(ct, body, params);
  r.score = testing::score_bone(r.bone, body, truth_bone, organs);
  return r;
}

std::int16_t clamp_hu(double hu) {
  return static_cast<std::int16_t>(std::clamp(std::lround(hu), -32768L, 32767L));
}

// Every HU moved by `offset` (a scanner calibrated differently).
LabelledCt shifted(const LabelledCt& d, double offset) {
  LabelledCt out = d;
  for (auto& v : out.ct.data) v = clamp_hu(v + offset);
  return out;
}

// Gaussian noise of `sigma` HU on every voxel (a lower dose, a sharper kernel, thinner slices
// averaged less); a fixed seed, so the figures repeat.
LabelledCt noisy(const LabelledCt& d, double sigma) {
  LabelledCt out = d;
  std::mt19937 random(13);
  std::normal_distribution<double> noise(0.0, sigma);
  for (auto& v : out.ct.data) v = clamp_hu(v + noise(random));
  return out;
}

// The CT smoothed by a [1 2 1]/4 kernel along each axis: a softer reconstruction kernel (or
// `gain` < 0 through sharpened()).
std::vector<double> smoothed(const CtVolume& ct) {
  const Grid& g = ct.grid;
  std::vector<double> a(ct.data.begin(), ct.data.end()), b(a.size());
  const std::int64_t stride[3] = {1, g.dims[0], g.dims[0] * g.dims[1]};
  for (int axis = 0; axis < 3; ++axis) {
    for (std::int64_t k = 0; k < g.dims[2]; ++k)
      for (std::int64_t j = 0; j < g.dims[1]; ++j)
        for (std::int64_t i = 0; i < g.dims[0]; ++i) {
          const std::int64_t at[3] = {i, j, k};
          const auto n = static_cast<std::int64_t>(g.linear(i, j, k));
          const std::int64_t lo = at[axis] > 0 ? n - stride[axis] : n;
          const std::int64_t hi = at[axis] + 1 < g.dims[axis] ? n + stride[axis] : n;
          b[static_cast<std::size_t>(n)] = 0.25 * a[static_cast<std::size_t>(lo)] +
                                           0.5 * a[static_cast<std::size_t>(n)] +
                                           0.25 * a[static_cast<std::size_t>(hi)];
        }
    std::swap(a, b);
  }
  return a;
}

// HU + gain * (HU - smoothed HU): gain > 0 a sharper (bone) kernel, with its overshoot at edges
// and its noise; gain -1 is the smoothing itself, a softer kernel.
LabelledCt sharpened(const LabelledCt& d, double gain) {
  LabelledCt out = d;
  const std::vector<double> smooth = smoothed(d.ct);
  for (std::size_t n = 0; n < out.ct.data.size(); ++n)
    out.ct.data[n] = clamp_hu(d.ct.data[n] + gain * (d.ct.data[n] - smooth[n]));
  return out;
}

// Contrast in the organs: the experts' organ voxels of soft-tissue HU (-30..150: not gas or fat)
// raised by `enhancement` HU, as an iodinated scan's liver, kidneys, spleen and vessels rise.
LabelledCt enhanced(const LabelledCt& d, double enhancement) {
  LabelledCt out = d;
  for (std::size_t n = 0; n < out.ct.data.size(); ++n)
    if (d.organs.data[n] && d.ct.data[n] >= -30 && d.ct.data[n] <= 150)
      out.ct.data[n] = clamp_hu(d.ct.data[n] + enhancement);
  return out;
}

// The bowel's gas: the pieces (6-connected) of the experts' organ label below -300 HU of which
// most voxels read below -900 HU. The label also holds the lung bases in the top slices, whose
// parenchyma reads -750 to -850 HU (the two pieces' medians on the shared CT), against -965 to
// -975 HU for the bowel's gas, so they are left out: positive oral contrast fills the bowel.
Mask bowel_gas(const LabelledCt& d) {
  const Grid& g = d.ct.grid;
  Mask gas(g, 0, "gas in the organ label");
  for (std::size_t n = 0; n < gas.data.size(); ++n)
    gas.data[n] = d.organs.data[n] && d.ct.data[n] < -300;
  const segmentation::RunTable runs = segmentation::extract_runs(gas, false);
  const segmentation::RunLabels labels = segmentation::label_runs(g, runs);
  const std::vector<std::int64_t> dark = segmentation::count_per_component(
      g, runs, labels, [&](std::size_t n) { return d.ct.data[n] < -900; });
  Mask bowel(g, 0, "bowel gas");
  segmentation::rewrite_runs(
      g, runs, labels,
      [&](std::int64_t c) {
        return static_cast<std::uint8_t>(2 * dark[static_cast<std::size_t>(c)] >
                                         labels.voxels[static_cast<std::size_t>(c)]);
      },
      bowel);
  return bowel;
}

// Positive oral contrast: the bowel's gas filled with `hu`, as a contrast-filled bowel reads.
LabelledCt oral_contrast(const LabelledCt& d, const Mask& bowel, double hu) {
  LabelledCt out = d;
  for (std::size_t n = 0; n < out.ct.data.size(); ++n)
    if (bowel.data[n]) out.ct.data[n] = clamp_hu(hu);
  return out;
}

// Slices twice as thick: each pair of slices averaged (HU), a label kept where it covers at
// least half of the new voxel (one of its two). The new slice's centre lies between the pair's.
template <class T>
Volume<T> paired_slices(const Volume<T>& v, const std::function<T(T, T)>& merge) {
  Grid g = v.grid;
  g.dims[2] = v.grid.dims[2] / 2;
  g.spacing[2] = 2.0 * v.grid.spacing[2];
  for (int a = 0; a < 3; ++a)
    g.world.origin[static_cast<std::size_t>(a)] +=
        0.5 * v.grid.spacing[2] * v.grid.world.direction[static_cast<std::size_t>(3 * a + 2)];
  Volume<T> out(g);
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i)
        out.at(i, j, k) = merge(v.at(i, j, 2 * k), v.at(i, j, 2 * k + 1));
  return out;
}

LabelledCt thicker_slices(const LabelledCt& d) {
  LabelledCt out;
  out.ct = paired_slices<std::int16_t>(d.ct, [](std::int16_t a, std::int16_t b) {
    return clamp_hu(0.5 * (static_cast<double>(a) + static_cast<double>(b)));
  });
  const auto half_or_more = [](std::uint8_t a, std::uint8_t b) -> std::uint8_t { return a || b; };
  out.truth_bone = paired_slices<std::uint8_t>(d.truth_bone, half_or_more);
  out.organs = paired_slices<std::uint8_t>(d.organs, half_or_more);
  return out;
}

// Slices half as thick: each new slice interpolated linearly between the two it lies between
// (HU), each label kept from the original slice at or below it. The
// anatomy stays as sharp as the 3 mm scan: this checks that the rules, set in mm, give the same
// bone on a grid twice as fine along the body, not what a real thin-slice scan resolves.
template <class T>
Volume<T> halved_slices(const Volume<T>& v, const std::function<T(T, T, double)>& between) {
  Grid g = v.grid;
  g.dims[2] = 2 * v.grid.dims[2] - 1;
  g.spacing[2] = 0.5 * v.grid.spacing[2];
  Volume<T> out(g);
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const std::int64_t below = k / 2, above = std::min(below + 1, v.grid.dims[2] - 1);
        out.at(i, j, k) = between(v.at(i, j, below), v.at(i, j, above), k % 2 == 0 ? 0.0 : 0.5);
      }
  return out;
}

LabelledCt thinner_slices(const LabelledCt& d) {
  LabelledCt out;
  out.ct = halved_slices<std::int16_t>(d.ct, [](std::int16_t a, std::int16_t b, double t) {
    return clamp_hu((1.0 - t) * a + t * b);
  });
  // A half-way slice takes the label of the slice below it: each label's extent along the body
  // moves by half a new slice (0.75 mm) at most.
  const auto label = [](std::uint8_t a, std::uint8_t, double) -> std::uint8_t { return a; };
  out.truth_bone = halved_slices<std::uint8_t>(d.truth_bone, label);
  out.organs = halved_slices<std::uint8_t>(d.organs, label);
  return out;
}

// Slices [first, first + count) only: a scan that starts and ends elsewhere.
template <class T>
Volume<T> slices(const Volume<T>& v, std::int64_t first, std::int64_t count) {
  Grid g = v.grid;
  g.dims[2] = count;
  for (int a = 0; a < 3; ++a)
    g.world.origin[static_cast<std::size_t>(a)] +=
        static_cast<double>(first) * v.grid.spacing[2] *
        v.grid.world.direction[static_cast<std::size_t>(3 * a + 2)];
  Volume<T> out(g);
  const std::size_t slice = static_cast<std::size_t>(g.dims[0] * g.dims[1]);
  std::copy(
      v.data.begin() + static_cast<std::ptrdiff_t>(slice * static_cast<std::size_t>(first)),
      v.data.begin() + static_cast<std::ptrdiff_t>(slice * static_cast<std::size_t>(first + count)),
      out.data.begin());
  return out;
}

LabelledCt cropped(const LabelledCt& d, std::int64_t first, std::int64_t count) {
  return {slices(d.ct, first, count), slices(d.truth_bone, first, count),
          slices(d.organs, first, count)};
}

// A mask stored in another axis order, through the CT's reordering (reorient.hpp).
Mask reorder_mask(const Mask& m, std::string_view code) {
  CtVolume as_ct(m.grid);
  for (std::size_t n = 0; n < m.data.size(); ++n) as_ct.data[n] = m.data[n];
  const CtVolume moved = reorder_axes(as_ct, code);
  Mask out(moved.grid);
  for (std::size_t n = 0; n < out.data.size(); ++n) out.data[n] = moved.data[n] != 0;
  return out;
}

LabelledCt stored_as(const LabelledCt& d, std::string_view code) {
  return {reorder_axes(d.ct, code), reorder_mask(d.truth_bone, code), reorder_mask(d.organs, code)};
}

void print_row(const std::string& name, const Result& r, const Result* baseline) {
  std::printf("| %s | %+.0f | %.3f | %.3f | %.3f | %.2f | %.3f |", name.c_str(), r.levels.offset_hu,
              r.score.dice, r.score.precision, r.score.recall, r.score.assd_mm, r.score.rib_recall);
  if (baseline && baseline->bone.grid.dims == r.bone.grid.dims)
    std::printf(" %.4f |\n", testing::dice(baseline->bone, r.bone));
  else
    std::printf(" — |\n");
}

class BoneRobustness : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    shared_ = new LabelledCt;
    if (!testing::load_labelled_shared_ct(*shared_)) {
      delete shared_;
      shared_ = nullptr;
      return;
    }
    baseline_ = new Result(segment_as_prep(shared_->ct, shared_->truth_bone, shared_->organs));
    std::printf(
        "| the shared CT | level offset HU | Dice | precision | recall | ASSD mm | rib recall | "
        "Dice with the unchanged CT's mask |\n|---|---|---|---|---|---|---|---|\n");
    print_row("as it is", *baseline_, nullptr);
  }
  static void TearDownTestSuite() {
    delete baseline_;
    delete shared_;
    baseline_ = nullptr;
    shared_ = nullptr;
  }
  void SetUp() override {
    if (shared_ == nullptr)
      GTEST_SKIP() << "the shared CT or its labels are not in the data folder";
  }
  static Result run(const std::string& name, const LabelledCt& d, bool same_grid = true) {
    Result r = segment_as_prep(d.ct, d.truth_bone, d.organs);
    print_row(name, r, same_grid ? baseline_ : nullptr);
    return r;
  }
  static LabelledCt* shared_;
  static Result* baseline_;
};

LabelledCt* BoneRobustness::shared_ = nullptr;
Result* BoneRobustness::baseline_ = nullptr;

// A scanner whose soft tissue reads some tens of HU off: the levels follow the soft-tissue peak,
// and every other rule is a fraction between HU or a shape, so the mask is the same.
TEST_F(BoneRobustness, CalibrationOffsets) {
  for (const double offset : {-15.0, 15.0, 30.0}) {
    const Result r =
        run((offset < 0 ? "every HU " : "every HU +") + std::to_string(static_cast<int>(offset)),
            shifted(*shared_, offset));
    EXPECT_NEAR(r.levels.offset_hu, baseline_->levels.offset_hu + offset, 1.0);
    EXPECT_GE(testing::dice(baseline_->bone, r.bone), 0.995) << offset;
    EXPECT_NEAR(r.score.dice, baseline_->score.dice, 0.003) << offset;
  }
}

TEST_F(BoneRobustness, Noise) {
  for (const double sigma : {10.0, 20.0, 40.0}) {
    const Result r = run("noise sigma " + std::to_string(static_cast<int>(sigma)) + " HU",
                         noisy(*shared_, sigma));
    EXPECT_GE(r.score.dice, baseline_->score.dice - 0.05) << sigma;
    EXPECT_GE(r.score.precision, 0.85) << sigma;
  }
}

// Contrast raises the organs, not bone or fat. Here every soft-tissue voxel the experts label —
// organs, bowel and the muscles TotalSegmentator outlines (paraspinal, psoas, gluteal), which a
// real scan enhances by only 10-20 HU — is raised alike: harsher than a contrast scan. The
// soft-tissue peak rises with them; the bone levels must not (hu_levels.hpp: upward only as far as
// fat confirms). At +50 HU the mask stays within 0.05 Dice of the plain scan's; at +100 and +150 HU
// the organs beside the bone reach the growing level and the mask is worse (docs/prep.md): the
// bounds there only keep it from getting worse unnoticed.
TEST_F(BoneRobustness, ContrastInTheOrgans) {
  for (const double enhancement : {50.0, 100.0, 150.0}) {
    const Result r =
        run("organs and labelled muscles +" + std::to_string(static_cast<int>(enhancement)) + " HU",
            enhanced(*shared_, enhancement));
    EXPECT_LE(r.levels.offset_hu, 0.0) << enhancement;
    EXPECT_EQ(r.score.organ_voxels_outside_body, 0) << enhancement;
    if (enhancement <= 50.0) {
      EXPECT_GE(r.score.dice, baseline_->score.dice - 0.05);
      EXPECT_GE(r.score.precision, 0.9);
    } else {
      EXPECT_GE(r.score.dice, 0.78) << enhancement;
      EXPECT_GE(r.score.precision, 0.78) << enhancement;
    }
  }
}

// Another reconstruction kernel: softer (the CT smoothed: thin ribs' peaks lowered) or sharper
// (an unsharp mask: edges overshoot, a dark rim beside the bone, a bright one on the skin). Half a
// step either way and a full sharpening hold. A full smoothing puts the thin ribs' peaks under the
// seed level: the ribs without a seed (bone_ribs.hpp) bring back those still at the growing level
// (rib recall 0.503 and 4.02 mm without them, 0.699 and 2.18 mm with). A doubled sharpening is the
// method's limit here (docs/prep.md): its bound only keeps it from getting worse unnoticed.
TEST_F(BoneRobustness, ReconstructionKernels) {
  const auto name = [](double gain) {
    char text[96];
    std::snprintf(text, sizeof text, "%s kernel: HU %s %.1f (HU - HU smoothed [1 2 1]/4)",
                  gain < 0 ? "softer" : "sharper", gain < 0 ? "-" : "+", std::fabs(gain));
    return std::string(text);
  };
  for (const double gain : {-0.5, 0.5, 1.0}) {
    const Result r = run(name(gain), sharpened(*shared_, gain));
    EXPECT_GE(r.score.dice, baseline_->score.dice - 0.015) << gain;
    EXPECT_GE(r.score.precision, 0.86) << gain;
    EXPECT_GE(r.score.rib_recall, baseline_->score.rib_recall - 0.09) << gain;
    EXPECT_LE(r.score.assd_mm, 2.5) << gain;
  }
  const Result soft = run(name(-1.0), sharpened(*shared_, -1.0));
  EXPECT_GE(soft.score.dice, 0.78);
  EXPECT_GE(soft.score.precision, 0.82);
  EXPECT_GE(soft.score.rib_recall, 0.65);
  EXPECT_LE(soft.score.assd_mm, 2.6);
  const Result sharp = run(name(2.0), sharpened(*shared_, 2.0));
  EXPECT_GE(sharp.score.dice, 0.78);
}

TEST_F(BoneRobustness, ThickerSlices) {
  const Result r = run("6 mm slices (pairs averaged)", thicker_slices(*shared_), false);
  EXPECT_GE(r.score.dice, 0.80);
  EXPECT_EQ(r.score.organ_voxels_outside_body, 0);
}

TEST_F(BoneRobustness, ThinnerSlices) {
  const LabelledCt thin = thinner_slices(*shared_);
  const Result r = run("1.5 mm slices (interpolated)", thin, false);
  EXPECT_GE(r.score.dice, baseline_->score.dice - 0.03);
  EXPECT_GE(r.score.rib_recall, baseline_->score.rib_recall - 0.05);
  const Result noisy_thin =
      run("1.5 mm slices (interpolated) + noise sigma 25 HU", noisy(thin, 25.0), false);
  EXPECT_GE(noisy_thin.score.dice, baseline_->score.dice - 0.05);
}

// A scan that starts and ends 36 mm further in: away from the new ends the mask is the one the
// whole scan gives; the new end slices are bone where the whole scan had bone.
TEST_F(BoneRobustness, ShorterScan) {
  const std::int64_t n = shared_->ct.grid.dims[2];
  const std::int64_t first = 12, count = n - 24;
  const LabelledCt part = cropped(*shared_, first, count);
  const Result r = run("slices 12.." + std::to_string(first + count - 1) + " only", part, false);
  const Mask whole = slices(baseline_->bone, first, count);
  std::printf("shorter scan: Dice with the whole scan's mask over the same slices %.4f\n",
              testing::dice(whole, r.bone));
  EXPECT_GE(testing::dice(whole, r.bone), 0.99);
  EXPECT_NEAR(r.score.dice,
              testing::score_bone(whole, segment_body(part.ct, SegmentationParams{}),
                                  part.truth_bone, part.organs)
                  .dice,
              0.01);
}

// Prone: the table in front of the patient. It is found there too (body_segmentation.cpp looks
// for it from both sides), and body and bone are the supine scan's, turned.
TEST_F(BoneRobustness, ProneWithTheTableInFront) {
  LabelledCt prone{testing::turned_about_body_axis(shared_->ct),
                   testing::turned_about_body_axis(shared_->truth_bone),
                   testing::turned_about_body_axis(shared_->organs)};
  SegmentationStats supine_stats, prone_stats;
  const Mask supine_body = segment_body(shared_->ct, SegmentationParams{}, &supine_stats);
  const Mask prone_body = segment_body(prone.ct, SegmentationParams{}, &prone_stats);
  ASSERT_GT(supine_stats.table_voxels, 1000u);
  EXPECT_EQ(prone_stats.table_voxels, supine_stats.table_voxels);
  const Mask body_back = testing::turned_about_body_axis(prone_body);
  EXPECT_EQ(testing::count(body_back), testing::count(supine_body));
  EXPECT_EQ(testing::count_both(body_back, supine_body), testing::count(supine_body));
  const Result r =
      run("prone (turned 180 degrees about the body axis: the table in front)", prone, false);
  const Mask bone_back = testing::turned_about_body_axis(r.bone);
  EXPECT_EQ(testing::count(bone_back), testing::count(baseline_->bone));
  EXPECT_EQ(testing::count_both(bone_back, baseline_->bone), testing::count(baseline_->bone));
}

// How much the result owes to the levels (docs/prep.md, "Bone levels from the scan"): the
// unchanged CT and its +50 HU organs row with the levels moved by fixed offsets instead of the
// scan's. Measures only; PALP_BONE_LEVEL_SWEEP=1 runs it.
TEST_F(BoneRobustness, LevelOffsetSweep) {
  if (std::getenv("PALP_BONE_LEVEL_SWEEP") == nullptr)
    GTEST_SKIP() << "set PALP_BONE_LEVEL_SWEEP=1";
  const LabelledCt contrast = enhanced(*shared_, 50.0);
  for (const double offset : {0.0, -5.0, -14.0, -24.0, -34.0, -44.0, -54.0}) {
    const Result plain =
        segment_as_prep(shared_->ct, shared_->truth_bone, shared_->organs, &offset);
    print_row("as it is, levels moved by a fixed offset", plain, nullptr);
    const Result raised =
        segment_as_prep(contrast.ct, contrast.truth_bone, contrast.organs, &offset);
    print_row("organs and labelled muscles +50 HU, the same offset", raised, nullptr);
  }
}

// Positive oral contrast (docs/prep.md): a contrast-filled bowel holds seeds, and its loops lie
// apart from the skeleton: filled lumens (remove_lumen_islands), not bone. Without that rule every
// one of the 13243 filled voxels is bone (Dice 0.800, ASSD 9.1 mm); with it none is, and the mask
// is the unchanged CT's.
TEST_F(BoneRobustness, OralContrast) {
  const Mask bowel = bowel_gas(*shared_);
  for (const double hu : {300.0, 450.0}) {
    const LabelledCt d = oral_contrast(*shared_, bowel, hu);
    const auto filled = static_cast<std::int64_t>(segmentation::count_nonzero(bowel));
    const Result r = run(
        "bowel gas filled with " + std::to_string(static_cast<int>(hu)) + " HU (oral contrast)", d);
    std::int64_t bone_in_bowel = 0;
    for (std::size_t n = 0; n < d.ct.data.size(); ++n)
      bone_in_bowel += r.bone.data[n] && bowel.data[n];
    std::printf("  %lld of the %lld filled voxels are bone\n",
                static_cast<long long>(bone_in_bowel), static_cast<long long>(filled));
    EXPECT_GT(filled, 10000) << "the bowel's gas";
    EXPECT_EQ(bone_in_bowel, 0) << hu << " HU";
    EXPECT_GE(testing::dice(baseline_->bone, r.bone), 0.995) << hu << " HU";
  }
}

// Stored as sagittal slices (another axis order, same patient): the same mask voxel for voxel.
TEST_F(BoneRobustness, AnotherStorageOrder) {
  const LabelledCt copy = stored_as(*shared_, "SLP");
  const Result r = run("stored SLP (sagittal slices)", copy, false);
  const Mask back = reorder_mask(baseline_->bone, "SLP");
  ASSERT_EQ(back.grid.dims, r.bone.grid.dims);
  EXPECT_EQ(testing::count(back), testing::count(r.bone));
  EXPECT_EQ(testing::count_both(back, r.bone), testing::count(back));
}

}  // namespace
}  // namespace palp
