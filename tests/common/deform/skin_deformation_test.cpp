// Tests for common/deform/skin_deformation.cpp: a fingertip pad pressed into a small synthetic
// volume. The anchored voxels hold exactly x_i - p_i and their mean is -u (paper eq. 13); the
// displacement is 0 outside the ROI and on its boundary, and the volume outside the written box
// is bit-identical to the original; inside, deformed(v) = original(v - d(v)) on a linear field
// (trilinear sampling reproduces it); releasing or moving the tool restores what it left bit for
// bit; update() allocates nothing after warm-up.
#include "deform/skin_deformation.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <vector>

#include "base/errors.hpp"
#include "support/heap_allocation_counter.hpp"

namespace palp {
namespace {

using Index3 = std::array<std::int64_t, 3>;

constexpr Index3 kDims{48, 44, 40};
constexpr std::array<double, 3> kSpacing{1.0, 1.0, 1.0};

std::int64_t voxel_index(std::int64_t i, std::int64_t j, std::int64_t k) {
  return i + kDims[0] * (j + kDims[1] * k);
}

// A linear field (exact for trilinear sampling) plus nothing else: value = 3i + 5j + 7k.
std::vector<float> linear_volume() {
  std::vector<float> v(static_cast<std::size_t>(kDims[0] * kDims[1] * kDims[2]));
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i)
        v[voxel_index(i, j, k)] = static_cast<float>(3 * i + 5 * j + 7 * k);
  return v;
}

// A finger:7 pad (centre + ring of 6 at 2.5 mm) with its proxies on the plane z = z_skin,
// pressed `depth` mm along -z with a small friction drag that differs per point.
std::vector<DeformContact> pad(double cx, double cy, double z_skin, double depth) {
  std::vector<DeformContact> contacts;
  for (int n = 0; n < 7; ++n) {
    const double angle = 2.0 * std::numbers::pi * (n - 1) / 6.0;
    const double r = n == 0 ? 0.0 : 2.5;
    const Vec3d p{cx + r * std::cos(angle), cy + r * std::sin(angle), z_skin};
    const Vec3d drag{0.25 * std::cos(n), -0.125 * std::sin(n), 0.0625 * n};
    contacts.push_back({p + Vec3d{0, 0, -depth} + drag, p});
  }
  return contacts;
}

Index3 nearest_voxel(const Vec3d& p) {
  return {std::llround(p.x / kSpacing[0]), std::llround(p.y / kSpacing[1]),
          std::llround(p.z / kSpacing[2])};
}

bool bit_identical(float a, float b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

bool inside(const Index3& lo, const Index3& hi, std::int64_t i, std::int64_t j, std::int64_t k) {
  return i >= lo[0] && i < hi[0] && j >= lo[1] && j < hi[1] && k >= lo[2] && k < hi[2];
}

TEST(SkinDeformer, RejectsBadInput) {
  EXPECT_THROW(SkinDeformer({4, 4, 0}, {1, 1, 1}, {}), UsageError);
  EXPECT_THROW(SkinDeformer({4, 4, 4}, {1, 0, 1}, std::vector<float>(64)), UsageError);
  EXPECT_THROW(SkinDeformer({4, 4, 4}, {1, 1, 1}, std::vector<float>(63)), UsageError);
  DeformerParams bad;
  bad.roi_margin_mm = -1;
  EXPECT_THROW(SkinDeformer({4, 4, 4}, {1, 1, 1}, std::vector<float>(64), bad), UsageError);
  SkinDeformer deformer({4, 4, 4}, {1, 1, 1}, std::vector<float>(64));
  std::vector<float> out(63);
  EXPECT_THROW(deformer.update({}, out), UsageError);
}

TEST(SkinDeformer, AnchorsHoldTheContactDisplacementsAndTheirMeanIsMinusU) {
  SkinDeformer deformer(kDims, kSpacing, linear_volume());
  std::vector<float> out = deformer.original();
  const auto contacts = pad(24.0, 22.0, 20.0, 4.0);
  const DeformResult result = deformer.update(contacts, out);
  ASSERT_TRUE(result.active);
  EXPECT_EQ(result.anchors, 7);

  Vec3d u{}, mean_anchor{};
  for (const auto& contact : contacts) {
    u += contact.p - contact.x;
    const Index3 v = nearest_voxel(contact.p);
    const Vec3d held = deformer.displacement_at(v[0], v[1], v[2]);
    EXPECT_EQ(held, contact.x - contact.p);  // exactly
    mean_anchor += held;
  }
  u *= 1.0 / 7.0;
  mean_anchor *= 1.0 / 7.0;
  EXPECT_EQ(mean_anchor, -u);
  EXPECT_EQ(result.mean_anchor_displacement, -u);
  EXPECT_LE(deformer.chainmail().max_violation(), 1e-9);
}

TEST(SkinDeformer, DeformationIsLocal) {
  DeformerParams params;
  params.roi_margin_mm = 20.0;  // (the default is 10 mm; any margin deforms alike)
  SkinDeformer deformer(kDims, kSpacing, linear_volume(), params);
  std::vector<float> out = deformer.original();
  const DeformResult result = deformer.update(pad(24.0, 22.0, 20.0, 5.0), out);
  ASSERT_TRUE(result.active);
  // The ROI reaches the margin (20 mm) around the pad, clipped to the volume.
  EXPECT_EQ(result.roi_lo, (Index3{2, 0, 0}));
  EXPECT_EQ(result.roi_hi, (Index3{48, 44, 40}));
  EXPECT_EQ(result.elements, 46 * 44 * 40);
  std::int64_t changed = 0;
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i) {
        const Vec3d d = deformer.displacement_at(i, j, k);
        const bool in_roi = inside(result.roi_lo, result.roi_hi, i, j, k);
        const bool on_roi_boundary =
            in_roi &&
            (i == result.roi_lo[0] || j == result.roi_lo[1] || k == result.roi_lo[2] ||
             i == result.roi_hi[0] - 1 || j == result.roi_hi[1] - 1 || k == result.roi_hi[2] - 1);
        if (!in_roi || on_roi_boundary) {
          ASSERT_EQ(d, Vec3d{}) << i << " " << j << " " << k;
        }
        const float original = deformer.original()[voxel_index(i, j, k)];
        if (!inside(result.lo, result.hi, i, j, k) || d == Vec3d{}) {
          ASSERT_TRUE(bit_identical(out[voxel_index(i, j, k)], original))
              << i << " " << j << " " << k;
        }
        changed += !bit_identical(out[voxel_index(i, j, k)], original);
      }
  EXPECT_GT(changed, 100);
  // The written box lies inside the ROI, off its boundary.
  for (int a = 0; a < 3; ++a) {
    EXPECT_GT(result.lo[a], result.roi_lo[a]);
    EXPECT_LT(result.hi[a], result.roi_hi[a]);
  }
}

TEST(SkinDeformer, ResamplesThroughTheDisplacement) {
  SkinDeformer deformer(kDims, kSpacing, linear_volume());
  std::vector<float> out = deformer.original();
  const DeformResult result = deformer.update(pad(24.0, 22.0, 20.0, 6.0), out);
  ASSERT_TRUE(result.active);
  double worst = 0.0;
  std::int64_t checked = 0;
  for (std::int64_t k = result.lo[2]; k < result.hi[2]; ++k)
    for (std::int64_t j = result.lo[1]; j < result.hi[1]; ++j)
      for (std::int64_t i = result.lo[0]; i < result.hi[0]; ++i) {
        const Vec3d d = deformer.displacement_at(i, j, k);
        const Vec3d source{i - d.x, j - d.y, k - d.z};  // spacing 1
        if (source.x < 0 || source.y < 0 || source.z < 0 || source.x > kDims[0] - 1 ||
            source.y > kDims[1] - 1 || source.z > kDims[2] - 1)
          continue;
        const double expected = 3 * source.x + 5 * source.y + 7 * source.z;
        // float storage: values up to ~600, rounding a few 1e-5 relative
        worst = std::max(worst, std::abs(out[voxel_index(i, j, k)] - expected));
        ++checked;
      }
  EXPECT_GT(checked, 1000);
  EXPECT_LE(worst, 2e-3);
  // At the centre anchor: the voxel shows what lay 6 mm (+ drag) above it.
  const Index3 centre = nearest_voxel({24.0, 22.0, 20.0});
  const Vec3d d = deformer.displacement_at(centre[0], centre[1], centre[2]);
  EXPECT_NEAR(d.z, -6.0, 1e-12);
  EXPECT_NEAR(out[voxel_index(centre[0], centre[1], centre[2])],
              3 * (24 - d.x) + 5 * (22 - d.y) + 7 * (20 - d.z), 2e-3);
}

TEST(SkinDeformer, ReleasingAndMovingRestoreBitForBit) {
  SkinDeformer deformer(kDims, kSpacing, linear_volume());
  std::vector<float> out = deformer.original();
  const DeformResult first = deformer.update(pad(16.0, 16.0, 20.0, 5.0), out);
  ASSERT_TRUE(first.active);
  // Slide far enough that the two written boxes only partly overlap.
  const DeformResult moved = deformer.update(pad(30.0, 26.0, 20.0, 3.0), out);
  ASSERT_TRUE(moved.active);
  for (int a = 0; a < 3; ++a) {  // the reported box covers both the old and the new one
    EXPECT_LE(moved.lo[a], first.lo[a]);
    EXPECT_GE(moved.hi[a], first.hi[a]);
  }
  std::int64_t differs_outside = 0;
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i)
        if (deformer.displacement_at(i, j, k) == Vec3d{})
          differs_outside +=
              !bit_identical(out[voxel_index(i, j, k)], deformer.original()[voxel_index(i, j, k)]);
  EXPECT_EQ(differs_outside, 0);

  const DeformResult released = deformer.update({}, out);
  EXPECT_FALSE(released.active);
  EXPECT_EQ(released.anchors, 0);
  EXPECT_EQ(std::memcmp(out.data(), deformer.original().data(), out.size() * sizeof(float)), 0);
  EXPECT_EQ(deformer.displacement_at(30, 26, 20), Vec3d{});
  // Released twice: nothing left to write.
  const DeformResult again = deformer.update({}, out);
  EXPECT_EQ(again.lo, again.hi);
  EXPECT_EQ(std::memcmp(out.data(), deformer.original().data(), out.size() * sizeof(float)), 0);
}

TEST(SkinDeformer, SkipsContactsOutsideTheVolume) {
  SkinDeformer deformer(kDims, kSpacing, linear_volume());
  std::vector<float> out = deformer.original();
  const std::vector<DeformContact> outside = {
      {{-5, 3, 3}, {-3, 3, 3}}, {{3, 3, 100}, {3, 3, 90}}, {{std::nan(""), 3, 3}, {3, 3, 3}}};
  const DeformResult result = deformer.update(outside, out);
  EXPECT_FALSE(result.active);
  EXPECT_EQ(std::memcmp(out.data(), deformer.original().data(), out.size() * sizeof(float)), 0);
}

// A contact a million millimetres from its proxy (a broken or hostile stream) moves its anchor
// only max_displacement_mm, direction kept, and the ROI stays the size that needs.
TEST(SkinDeformer, FarContactIsClampedToWhatAToolCanDo) {
  DeformerParams params;
  params.max_displacement_mm = 4.0;
  SkinDeformer deformer(kDims, kSpacing, linear_volume(), params);
  std::vector<float> out = deformer.original();
  const Vec3d p{24.0, 22.0, 20.0};
  const std::vector<DeformContact> far = {{p + Vec3d{0, 0, -1e6}, p}};
  const DeformResult result = deformer.update(far, out);
  ASSERT_TRUE(result.active);
  const Index3 v = nearest_voxel(p);
  EXPECT_EQ(deformer.displacement_at(v[0], v[1], v[2]), (Vec3d{0, 0, -4.0}));
  DeformResult near_result;
  {
    SkinDeformer reference(kDims, kSpacing, linear_volume(), params);
    std::vector<float> out2 = reference.original();
    const std::vector<DeformContact> near = {{p + Vec3d{0, 0, -4.0}, p}};
    near_result = reference.update(near, out2);
  }
  EXPECT_EQ(result.roi_lo, near_result.roi_lo);  // the same box as an honest 4 mm press
  EXPECT_EQ(result.roi_hi, near_result.roi_hi);
  params.max_displacement_mm = 0.0;
  EXPECT_THROW(SkinDeformer(kDims, kSpacing, linear_volume(), params), UsageError);
}

// A volume finer than lattice_mm (0.5 mm voxels, 1.6 mm: 3 voxels an element): the ChainMail
// runs on every third voxel, the voxels between take the trilinear interpolation of the elements'
// displacements, the voxels with none are untouched bit for bit, the anchor's voxel is displaced
// as the contact asks, and releasing restores the original exactly.
TEST(SkinDeformer, FinerVoxelsRunTheChainMailOnACoarserLattice) {
  const std::array<double, 3> fine{0.5, 0.5, 0.5};
  SkinDeformer deformer(kDims, fine, linear_volume());
  std::vector<float> out = deformer.original();
  // One contact at voxel (24, 21, 21) = 12, 10.5, 10.5 mm (an element: multiples of 3), 2 mm down.
  const Vec3d p{12.0, 10.5, 10.5};
  const DeformResult r =
      deformer.update(std::vector<DeformContact>{{p + Vec3d{0, 0, -2.0}, p}}, out);
  ASSERT_TRUE(r.active);
  EXPECT_EQ(r.lattice, (Index3{3, 3, 3}));
  for (int a = 0; a < 3; ++a) EXPECT_EQ(r.roi_lo[a] % 3, 0);
  EXPECT_EQ(deformer.displacement_at(24, 21, 21), (Vec3d{0, 0, -2.0}));
  // Between elements: the interpolation of the two neighbours along i.
  const Vec3d e0 = deformer.displacement_at(27, 21, 21), e1 = deformer.displacement_at(30, 21, 21);
  const Vec3d mid = deformer.displacement_at(28, 21, 21);
  EXPECT_NEAR(mid.z, e0.z + (e1.z - e0.z) / 3.0, 1e-12);
  EXPECT_LT(e0.z, 0.0);
  std::int64_t untouched_differ = 0, moved = 0;
  for (std::int64_t k = 0; k < kDims[2]; ++k)
    for (std::int64_t j = 0; j < kDims[1]; ++j)
      for (std::int64_t i = 0; i < kDims[0]; ++i) {
        const std::int64_t v = voxel_index(i, j, k);
        const Vec3d d = deformer.displacement_at(i, j, k);
        if (d == Vec3d{}) {
          untouched_differ += !bit_identical(out[v], deformer.original()[v]);
          continue;
        }
        ++moved;
        EXPECT_TRUE(inside(r.lo, r.hi, i, j, k));
        // linear field: the sample at (i, j, k) - d / spacing, exactly up to float rounding
        const double want = 3 * (i - 2 * d.x) + 5 * (j - 2 * d.y) + 7 * (k - 2 * d.z);
        if (i - 2 * d.x >= 0 && j - 2 * d.y >= 0 && k - 2 * d.z >= 0) {
          EXPECT_NEAR(out[v], want, 2e-3);
        }
      }
  EXPECT_EQ(untouched_differ, 0);
  EXPECT_GT(moved, 27);
  const DeformResult released = deformer.update({}, out);
  EXPECT_FALSE(released.active);
  EXPECT_EQ(std::memcmp(out.data(), deformer.original().data(), out.size() * sizeof(float)), 0);
}

TEST(SkinDeformer, NoAllocationPerUpdateAfterWarmUp) {
  SkinDeformer deformer(kDims, kSpacing, linear_volume());
  std::vector<float> out = deformer.original();
  std::vector<std::vector<DeformContact>> frames;
  for (int f = 0; f < 8; ++f) frames.push_back(pad(20.0 + 0.5 * f, 20.0 + 0.25 * f, 20.0, 5.0));
  for (const auto& frame : frames) deformer.update(frame, out);  // warm-up: the largest ROI
  g_allocations = 0;
  g_count_allocations = true;
  for (const auto& frame : frames) deformer.update(frame, out);
  deformer.update({}, out);
  g_count_allocations = false;
  EXPECT_EQ(g_allocations.load(), 0);
  EXPECT_EQ(std::memcmp(out.data(), deformer.original().data(), out.size() * sizeof(float)), 0);
}

// Image headers store spacings as float32: 0.8f is 0.800000011920929 mm, and 1.6 mm elements
// must still span 2 voxels there (they spanned 1 before: four times the elements in palpview on
// the full-resolution CT). A spacing just too coarse for 2 still gets 1.
TEST(SkinDeformer, Float32SpacingGetsTheIntendedLattice) {
  const auto lattice_for = [](std::array<double, 3> spacing) {
    SkinDeformer deformer(kDims, spacing, linear_volume());
    std::vector<float> out = deformer.original();
    const Vec3d p{10.0, 10.0, 10.0};
    return deformer.update(std::vector<DeformContact>{{p + Vec3d{0, 0, -2.0}, p}}, out).lattice;
  };
  EXPECT_EQ(lattice_for({double(0.8f), double(0.8f), double(1.0f)}), (Index3{2, 2, 1}));
  EXPECT_EQ(lattice_for({0.8, 0.8, 1.0}), (Index3{2, 2, 1}));
  EXPECT_EQ(lattice_for({double(0.5f), double(0.53f), double(0.4f)}), (Index3{3, 3, 4}));
  EXPECT_EQ(lattice_for({double(0.81f), 1.0, 2.0}), (Index3{1, 1, 1}));
}

// The ROI margin only sizes the ChainMail box: the reach computed from the displacement keeps the
// deformation inside it, so margins of 0, 10 (the default), 20 and 40 mm write the same volume
// bit for bit over a sliding press that also lifts and lands again (the box changes layout on
// every frame), on an element a voxel and on a coarser lattice; a larger margin only makes the
// box larger.
TEST(SkinDeformer, AnyRoiMarginGivesTheSameDeformation) {
  for (const auto& spacing :
       {std::array<double, 3>{1.0, 1.0, 1.0}, std::array<double, 3>{0.5, 0.5, 0.8}}) {
    std::vector<std::vector<float>> outs;
    std::vector<std::int64_t> elements;
    for (const double margin : {0.0, 10.0, 20.0, 40.0}) {
      DeformerParams params;
      params.roi_margin_mm = margin;
      SkinDeformer deformer(kDims, spacing, linear_volume(), params);
      std::vector<float> out = deformer.original();
      std::vector<float> frames;
      std::int64_t largest = 0;
      for (int f = 0; f < 6; ++f) {
        const double s = spacing[0] * 24.0;  // the volume's middle along i, mm
        const auto contacts = f == 3 ? std::vector<DeformContact>{}
                                     : pad(s - 3.0 + 1.3 * f, spacing[1] * 20.0 + 0.4 * f,
                                           spacing[2] * 30.0, 3.0 + 0.5 * f);
        const DeformResult r = deformer.update(contacts, out);
        largest = std::max(largest, r.elements);
        frames.insert(frames.end(), out.begin(), out.end());
      }
      outs.push_back(std::move(frames));
      elements.push_back(largest);
    }
    for (std::size_t m = 1; m < outs.size(); ++m) {
      ASSERT_EQ(outs[m].size(), outs[0].size());
      EXPECT_EQ(std::memcmp(outs[m].data(), outs[0].data(), outs[0].size() * sizeof(float)), 0)
          << "margin #" << m << ", spacing " << spacing[0];
      EXPECT_GE(elements[m], elements[m - 1]);
    }
    EXPECT_GT(elements.back(), elements.front());
  }
}

}  // namespace
}  // namespace palp
