// The same patient stored in several orientations is the same patient: prep's masks agree voxel
// for voxel once mapped back (RAS, reversed slices, permuted axes) or within interpolation
// (oblique, resampled), and --side auto presses the same anatomical spot (patient coordinates).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>

#include "base/patient_frame.hpp"
#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "model/field_sampler.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/reorient.hpp"
#include "prep/segment/segmentation.hpp"
#include "scene/trajectory_gen.hpp"
#include "support/torso_scenes.hpp"

namespace palp {
namespace {

// The torso's field of view at 3 x 3 x 4 mm: 160 x 107 x 48 voxels.
CtVolume torso() {
  return testing::coarse_torso();
}

Vec3d column(const Grid& g, int a) {
  const auto& d = g.world.direction;
  return {d[static_cast<std::size_t>(a)], d[static_cast<std::size_t>(3 + a)],
          d[static_cast<std::size_t>(6 + a)]};
}

Vec3d world_of(const Grid& g, const Vec3d& scene) {
  return world_of_scene(g, scene);
}

void set_column(Grid& g, int a, const Vec3d& c) {
  g.world.direction[static_cast<std::size_t>(a)] = c.x;
  g.world.direction[static_cast<std::size_t>(3 + a)] = c.y;
  g.world.direction[static_cast<std::size_t>(6 + a)] = c.z;
}

// A copy stored with index (i', j', k') = map(i, j, k): same voxels, same world.
template <class T>
Volume<T> restore(const Volume<T>& v, const Grid& g,
                  const std::function<Index3(Index3)>& index_in_v) {
  Volume<T> out(g);
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const Index3 s = index_in_v({i, j, k});
        out.at(i, j, k) = v.at(s[0], s[1], s[2]);
      }
  return out;
}

struct Stored {
  std::string name;
  CtVolume ct;
  std::function<Index3(Index3)> index;  // original voxel -> this copy's voxel
};

// RAS: i and j reversed. Reversed slices: k reversed. Permuted: (i', j', k') = (k, i, j).
std::vector<Stored> stored_copies(const CtVolume& ct) {
  const Grid& g = ct.grid;
  const Index3 n = g.dims;
  std::vector<Stored> out;
  {
    Grid r = g;
    set_column(r, 0, -column(g, 0));
    set_column(r, 1, -column(g, 1));
    r.world.origin = to_vec3(world_of(g, {static_cast<double>(n[0] - 1) * g.spacing[0],
                                          static_cast<double>(n[1] - 1) * g.spacing[1], 0}));
    auto to_copy = [n](Index3 o) { return Index3{n[0] - 1 - o[0], n[1] - 1 - o[1], o[2]}; };
    out.push_back({"RAS", restore(ct, r, to_copy), to_copy});  // its own inverse
  }
  {
    Grid r = g;
    set_column(r, 2, -column(g, 2));
    r.world.origin = to_vec3(world_of(g, {0, 0, static_cast<double>(n[2] - 1) * g.spacing[2]}));
    auto to_copy = [n](Index3 o) { return Index3{o[0], o[1], n[2] - 1 - o[2]}; };
    out.push_back({"reversed slices", restore(ct, r, to_copy), to_copy});
  }
  {
    Grid r = g;
    r.dims = {n[2], n[0], n[1]};
    r.spacing = {g.spacing[2], g.spacing[0], g.spacing[1]};
    set_column(r, 0, column(g, 2));
    set_column(r, 1, column(g, 0));
    set_column(r, 2, column(g, 1));
    auto to_copy = [](Index3 o) { return Index3{o[2], o[0], o[1]}; };
    auto from_copy = [](Index3 c) { return Index3{c[1], c[2], c[0]}; };
    out.push_back({"permuted", restore(ct, r, from_copy), to_copy});
  }
  return out;
}

std::int64_t mismatches(const Mask& original, const Mask& copy,
                        const std::function<Index3(Index3)>& index) {
  std::int64_t n = 0;
  const Grid& g = original.grid;
  for (std::int64_t k = 0; k < g.dims[2]; ++k)
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const Index3 c = index({i, j, k});
        n += original.at(i, j, k) != copy.at(c[0], c[1], c[2]);
      }
  return n;
}

TEST(ReorientedScene, CopiesAreStoredDifferently) {
  const CtVolume ct = torso();
  const auto copies = stored_copies(ct);
  EXPECT_EQ(patient_frame(ct.grid).orientation_code(), "LPS");
  EXPECT_EQ(patient_frame(copies[0].ct.grid).orientation_code(), "RAS");
  EXPECT_EQ(patient_frame(copies[1].ct.grid).orientation_code(), "LPI");
  EXPECT_EQ(patient_frame(copies[2].ct.grid).orientation_code(), "SLP");
}

TEST(ReorientedScene, PrepFindsTheSameAnatomy) {
  const CtVolume ct = torso();
  const SegmentationParams params;
  const Mask body = segment_body(ct, params);
  const Mask bone = segment_bone(ct, body, params);
  for (const Stored& s : stored_copies(ct)) {
    SCOPED_TRACE(s.name);
    const Mask b = segment_body(s.ct, params);
    EXPECT_EQ(mismatches(body, b, s.index), 0);
    EXPECT_EQ(mismatches(bone, segment_bone(s.ct, b, params), s.index), 0);
  }
}

SurfaceAnchor auto_anchor(const CtVolume& ct) {
  const SegmentationParams params;
  const Mask body = segment_body(ct, params);
  FieldSampler fields(signed_distance(body));
  return find_surface_anchor(fields, ApproachSide::Auto);
}

TEST(ReorientedScene, SideAutoPressesTheSameSpot) {
  const CtVolume ct = torso();
  const SurfaceAnchor a = auto_anchor(ct);
  const Vec3d where = world_of(ct.grid, a.point);
  const Vec3d normal = world_of(ct.grid, a.normal) - to_vec3d(ct.grid.world.origin);
  // The anterior wall: the outward normal points anterior (-y in LPS).
  EXPECT_LT(normal.y, -0.9);
  for (const Stored& s : stored_copies(ct)) {
    SCOPED_TRACE(s.name);
    const SurfaceAnchor b = auto_anchor(s.ct);
    const Vec3d there = world_of(s.ct.grid, b.point);
    EXPECT_LE(norm(there - where), 3.0) << "more than a voxel apart";
    const Vec3d n = world_of(s.ct.grid, b.normal) - to_vec3d(s.ct.grid.world.origin);
    EXPECT_GT(dot(n, normal), 0.99);
    const Vec3d slide = world_of(s.ct.grid, b.slide) - to_vec3d(s.ct.grid.world.origin);
    const Vec3d slide0 = world_of(ct.grid, a.slide) - to_vec3d(ct.grid.world.origin);
    EXPECT_GT(dot(slide, slide0), 0.99);  // toward the patient's left in both
  }
}

TEST(ReorientedScene, ObliqueCopyIsResampledToTheSameAnatomy) {
  const CtVolume ct = torso();
  // A 12 degree gantry tilt: the copy's grid turned about the left-right axis.
  const double t = 12.0 * 3.14159265358979323846 / 180.0;
  Grid tilted = ct.grid;
  set_column(tilted, 1, {0, std::cos(t), std::sin(t)});
  set_column(tilted, 2, {0, -std::sin(t), std::cos(t)});
  tilted.dims = {160, 120, 60};
  const Vec3d centre = world_of(ct.grid, to_vec3d(ct.grid.extent_mm()) * 0.5);
  const Vec3 half = tilted.extent_mm();
  tilted.world.origin =
      to_vec3(centre - column(tilted, 0) * (half[0] / 2) - column(tilted, 1) * (half[1] / 2) -
              column(tilted, 2) * (half[2] / 2));
  const CtVolume oblique = resample(ct, tilted);
  ASSERT_NEAR(patient_frame(oblique.grid).obliquity_deg(), 12.0, 1e-9);

  const CtVolume aligned = resample_axis_aligned(oblique);
  EXPECT_EQ(patient_frame(aligned.grid).orientation_code(), "LPS");
  EXPECT_EQ(patient_frame(aligned.grid).obliquity_deg(), 0.0);

  const SegmentationParams params;
  const Mask body = segment_body(ct, params);
  const Mask body2 = segment_body(aligned, params);
  // Body voxels of the original, looked up (nearest voxel) in the resampled copy.
  std::int64_t both = 0, a = 0, b = 0;
  const Grid& g = ct.grid;
  for (std::int64_t k = 2; k < g.dims[2] - 2; ++k)  // the tilt cuts the first and last slices
    for (std::int64_t j = 0; j < g.dims[1]; ++j)
      for (std::int64_t i = 0; i < g.dims[0]; ++i) {
        const Vec3d w = world_of(g, {i * g.spacing[0], j * g.spacing[1], k * g.spacing[2]});
        const Vec3d r = w - to_vec3d(aligned.grid.world.origin);
        const Index3 c{std::llround(dot(column(aligned.grid, 0), r) / aligned.grid.spacing[0]),
                       std::llround(dot(column(aligned.grid, 1), r) / aligned.grid.spacing[1]),
                       std::llround(dot(column(aligned.grid, 2), r) / aligned.grid.spacing[2])};
        const bool in2 = aligned.grid.contains(c[0], c[1], c[2]) && body2.at(c[0], c[1], c[2]);
        const bool in1 = body.at(i, j, k) != 0;
        both += in1 && in2;
        a += in1;
        b += in2;
      }
  const double dice = 2.0 * static_cast<double>(both) / static_cast<double>(a + b);
  EXPECT_GT(dice, 0.97);
  // --side auto on the resampled copy presses the same anterior spot, within two voxels (two
  // interpolations and the tilt's staircase).
  const SurfaceAnchor a0 = auto_anchor(ct), a1 = auto_anchor(aligned);
  EXPECT_LE(norm(world_of(ct.grid, a0.point) - world_of(aligned.grid, a1.point)), 6.0);
}

// The shared real CT (stored RAS) and the same voxels stored LPS: the same masks voxel for voxel
// and the same pressed spot. Skips when ../shared/data is absent.
TEST(ReorientedScene, RealCtStoredLpsIsTheSamePatient) {
  const std::string path = std::string(PALP_SHARED_DATA_DIR) + "/ct_abdomen_3mm.nii.gz";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not found";
  const CtVolume ras = read_ct(path);
  ASSERT_EQ(patient_frame(ras.grid).orientation_code(), "RAS");
  const CtVolume lps = reorder_axes(ras, "LPS");
  const Index3 n = ras.grid.dims;
  const auto index = [n](Index3 o) { return Index3{n[0] - 1 - o[0], n[1] - 1 - o[1], o[2]}; };
  const SegmentationParams params;
  const Mask body = segment_body(ras, params);
  const Mask body_lps = segment_body(lps, params);
  EXPECT_EQ(mismatches(body, body_lps, index), 0);
  EXPECT_EQ(mismatches(segment_bone(ras, body, params), segment_bone(lps, body_lps, params), index),
            0);
  const SurfaceAnchor a = auto_anchor(ras), b = auto_anchor(lps);
  EXPECT_LE(norm(world_of(ras.grid, a.point) - world_of(lps.grid, b.point)), 3.0);
  // The anterior skin: the outward normal points anterior (-y in LPS world).
  const Vec3d normal = world_of(ras.grid, a.normal) - to_vec3d(ras.grid.world.origin);
  EXPECT_LT(normal.y, -0.7);
}

}  // namespace
}  // namespace palp
