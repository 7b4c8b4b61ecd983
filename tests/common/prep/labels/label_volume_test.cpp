// Tests for label_volume.hpp: stored values read slab by slab, checked and counted, and put on the
// CT's grid nearest-neighbour through both world placements. The label files are raw bytes (or
// gzip) described by a hand-made StoredImage; the expected voxels follow from the geometry.
#include "prep/labels/label_volume.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <vector>

#include "base/errors.hpp"
#include "io/gzip.hpp"
#include "support/io_test_util.hpp"

namespace palp::labels {
namespace {

using testing::TempDir;
using testing::write_bytes;

Grid grid(Index3 dims, Vec3 spacing = {1, 1, 1}, Vec3 origin = {0, 0, 0},
          std::array<double, 9> direction = {1, 0, 0, 0, 1, 0, 0, 0, 1}) {
  Grid g;
  g.dims = dims;
  g.spacing = spacing;
  g.world.origin = origin;
  g.world.direction = direction;
  return g;
}

LabelVolume raw_volume(const std::string& path, const Grid& g, ScalarType type,
                       std::int64_t components = 1) {
  LabelVolume v;
  v.image.grid = g;
  v.image.voxels.path = path;
  v.image.voxels.type = type;
  v.components = components;
  v.name = path;
  return v;
}

// Value v of component 0 is class v - 1 (values 1..n).
LabelLookup classes_by_value(std::int32_t n) {
  LabelLookup lookup{{{LabelLookup::kBackground}}};
  for (std::int32_t c = 0; c < n; ++c) lookup.table[0].push_back(c);
  return lookup;
}

// Reads `v` onto `ct` with one mask per class, allocated on first use.
struct Read {
  std::map<std::int32_t, Mask> masks;
  LabelCounts counts;
};

Read read(const LabelVolume& v, const Grid& ct, const LabelLookup& lookup, std::size_t classes,
          std::size_t slab_values = kSlabValues) {
  Read out;
  out.counts = read_labels(
      v, ct, lookup, classes,
      [&](std::int32_t cls) {
        auto [it, fresh] = out.masks.try_emplace(cls);
        if (fresh) it->second = Mask(ct);
        return ClassTarget{&it->second, 1};
      },
      slab_values);
  return out;
}

TEST(LabelVolume, SameGridIsCopiedAndCounted) {
  TempDir dir;
  const Grid g = grid({4, 3, 2});
  std::vector<std::uint8_t> values(24, 0);
  values[1] = 1;   // (1, 0, 0)
  values[14] = 2;  // (2, 0, 1): 2 + 4 * (0 + 3 * 1)
  values[23] = 2;  // (3, 2, 1)
  write_bytes(dir.file("l.raw"), values);
  const Read r = read(raw_volume(dir.file("l.raw"), g, ScalarType::u8), g, classes_by_value(2), 2);
  EXPECT_FALSE(r.counts.resampled);
  EXPECT_EQ(r.counts.in_file, (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(r.counts.on_ct, (std::vector<std::uint64_t>{1, 2}));
  EXPECT_EQ(r.counts.labelled_in_file, 3u);
  EXPECT_EQ(r.counts.ct_covered, 24u);
  EXPECT_EQ(r.counts.max_value, 2u);
  EXPECT_EQ(r.counts.undefined, 0u);
  std::vector<std::uint8_t> first(24, 0), second(24, 0);
  first[1] = 1;
  second[14] = second[23] = 1;
  EXPECT_EQ(r.masks.at(0).data, first);
  EXPECT_EQ(r.masks.at(1).data, second);
}

// 3D Slicer crops a segmentation to its segments' box: the CT's lattice, shifted by whole voxels.
TEST(LabelVolume, BoxOfTheCtGridIsPlacedWithoutResampling) {
  TempDir dir;
  const Grid ct = grid({4, 3, 2}, {0.5, 0.5, 2}, {10, 20, 30});
  const Grid box = grid({2, 2, 1}, {0.5, 0.5, 2}, {11, 20.5, 32});        // from CT voxel (2, 1, 1)
  write_bytes(dir.file("l.raw"), std::vector<std::uint8_t>{0, 1, 1, 0});  // (1,0) and (0,1)
  const Read r =
      read(raw_volume(dir.file("l.raw"), box, ScalarType::u8), ct, classes_by_value(1), 1);
  EXPECT_FALSE(r.counts.resampled);
  EXPECT_EQ(r.counts.ct_covered, 4u);
  std::vector<std::uint8_t> expected(24, 0);
  expected[ct.linear(3, 1, 1)] = expected[ct.linear(2, 2, 1)] = 1;
  EXPECT_EQ(r.masks.at(0).data, expected);
}

// A 2 mm label map whose first voxel centre is at x = y = 0.5 mm: CT voxels i = 0, 1 (x = 0, 1 mm)
// are nearest to label voxel 0 (0.5 mm), i = 2, 3 to label voxel 1 (2.5 mm); the same along j.
TEST(LabelVolume, CoarserGridIsResampledNearestNeighbour) {
  TempDir dir;
  const Grid ct = grid({4, 4, 1});
  const Grid labels = grid({2, 2, 1}, {2, 2, 2}, {0.5, 0.5, 0});
  write_bytes(dir.file("l.raw"), std::vector<std::uint8_t>{1, 0, 0, 1});  // (0,0) and (1,1)
  const Read r =
      read(raw_volume(dir.file("l.raw"), labels, ScalarType::u8), ct, classes_by_value(1), 1);
  EXPECT_TRUE(r.counts.resampled);
  EXPECT_EQ(r.counts.in_file[0], 2u);
  EXPECT_EQ(r.counts.on_ct[0], 8u);
  std::vector<std::uint8_t> expected(16, 0);
  for (std::int64_t j = 0; j < 4; ++j)
    for (std::int64_t i = 0; i < 4; ++i) expected[ct.linear(i, j, 0)] = (i < 2) == (j < 2);
  EXPECT_EQ(r.masks.at(0).data, expected);
}

// Stored right-to-left and anterior-to-posterior (direction -x, -y) with its first voxel at the
// CT's far corner: label voxel (a, b, c) is CT voxel (3 - a, 2 - b, c).
TEST(LabelVolume, MirroredAxesFollowTheWorldPlacement) {
  TempDir dir;
  const Grid ct = grid({4, 3, 2});
  const Grid labels = grid({4, 3, 2}, {1, 1, 1}, {3, 2, 0}, {-1, 0, 0, 0, -1, 0, 0, 0, 1});
  std::vector<std::uint8_t> values(24, 0);
  values[labels.linear(0, 0, 1)] = 1;
  write_bytes(dir.file("l.raw"), values);
  const Read r =
      read(raw_volume(dir.file("l.raw"), labels, ScalarType::u8), ct, classes_by_value(1), 1);
  EXPECT_TRUE(r.counts.resampled);
  std::vector<std::uint8_t> expected(24, 0);
  expected[ct.linear(3, 2, 1)] = 1;
  EXPECT_EQ(r.masks.at(0).data, expected);
}

// Label axes permuted (i along world y, j along z, k along x): a CT row along x crosses every label
// slice, so each slab writes part of every row. Label voxel (a, b, c) is CT voxel (c, a, b).
TEST(LabelVolume, PermutedAxesAcrossSlabs) {
  TempDir dir;
  const Grid ct = grid({5, 4, 3});
  const Grid labels = grid({4, 3, 5}, {1, 1, 1}, {0, 0, 0}, {0, 0, 1, 1, 0, 0, 0, 1, 0});
  std::vector<std::uint8_t> values(60);
  for (std::int64_t c = 0; c < 5; ++c)
    for (std::int64_t b = 0; b < 3; ++b)
      for (std::int64_t a = 0; a < 4; ++a)
        values[labels.linear(a, b, c)] = static_cast<std::uint8_t>((a + 2 * b + 3 * c) % 3);
  write_bytes(dir.file("l.raw"), values);
  for (const std::size_t slab : {std::size_t{12}, std::size_t{24}, std::size_t{1000}}) {
    const Read r = read(raw_volume(dir.file("l.raw"), labels, ScalarType::u8), ct,
                        classes_by_value(2), 2, slab);
    for (std::int64_t k = 0; k < 3; ++k)
      for (std::int64_t j = 0; j < 4; ++j)
        for (std::int64_t i = 0; i < 5; ++i) {
          const int value = static_cast<int>((j + 2 * k + 3 * i) % 3);
          EXPECT_EQ(r.masks.at(0).at(i, j, k), value == 1 ? 1 : 0) << slab << " " << i << j << k;
          EXPECT_EQ(r.masks.at(1).at(i, j, k), value == 2 ? 1 : 0) << slab << " " << i << j << k;
        }
    EXPECT_EQ(r.counts.ct_covered, 60u);
  }
}

// Two layers (3D Slicer's overlapping segments): component c of a voxel has its own table.
TEST(LabelVolume, LayersHaveTheirOwnValues) {
  TempDir dir;
  const Grid g = grid({2, 1, 1});
  write_bytes(dir.file("l.raw"), std::vector<std::uint8_t>{1, 1, 0, 1});  // (layer0, layer1) x 2
  LabelLookup lookup;
  lookup.table = {{LabelLookup::kBackground, 0}, {LabelLookup::kBackground, 1}};
  const Read r = read(raw_volume(dir.file("l.raw"), g, ScalarType::u8, 2), g, lookup, 2);
  EXPECT_EQ(r.masks.at(0).data, (std::vector<std::uint8_t>{1, 0}));
  EXPECT_EQ(r.masks.at(1).data, (std::vector<std::uint8_t>{1, 1}));
  EXPECT_EQ(r.counts.labelled_in_file, 2u);
}

// Two classes into one volume with their own values (palp's structure ids): a voxel written by
// both is an overlap, the first one recorded.
TEST(LabelVolume, OverlapsInOneTargetVolumeAreCounted) {
  TempDir dir;
  const Grid g = grid({2, 1, 1});
  write_bytes(dir.file("l.raw"), std::vector<std::uint8_t>{1, 1, 0, 1});  // (layer0, layer1) x 2
  LabelLookup lookup;
  lookup.table = {{LabelLookup::kBackground, 0}, {LabelLookup::kBackground, 1}};
  Mask ids(g);
  const LabelCounts counts = read_labels(
      raw_volume(dir.file("l.raw"), g, ScalarType::u8, 2), g, lookup, 2, [&](std::int32_t cls) {
        return ClassTarget{&ids, static_cast<std::uint8_t>(cls + 7)};
      });
  EXPECT_EQ(counts.overlaps, 1u);
  EXPECT_EQ(counts.overlap_at, 0u);
  EXPECT_EQ(counts.overlap_previous, 7);
  EXPECT_EQ(counts.overlap_class, 1);
  EXPECT_EQ(ids.data, (std::vector<std::uint8_t>{8, 8}));
}

TEST(LabelVolume, UndefinedValuesAreCountedNotWritten) {
  TempDir dir;
  const Grid g = grid({3, 1, 1});
  write_bytes(dir.file("l.raw"), std::vector<std::uint8_t>{1, 7, 7});
  const Read r = read(raw_volume(dir.file("l.raw"), g, ScalarType::u8), g, classes_by_value(1), 1);
  EXPECT_EQ(r.counts.undefined, 2u);
  EXPECT_EQ(r.counts.undefined_value, 7u);
  EXPECT_EQ(r.counts.max_value, 7u);
  EXPECT_EQ(r.masks.at(0).data, (std::vector<std::uint8_t>{1, 0, 0}));
}

TEST(LabelVolume, WholeNumbersInAnyTypeAndScaling) {
  TempDir dir;
  const Grid g = grid({3, 1, 1});
  write_bytes(dir.file("f.raw"), testing::payload(std::vector<float>{0, 2, 1}));
  Read r = read(raw_volume(dir.file("f.raw"), g, ScalarType::f32), g, classes_by_value(2), 2);
  EXPECT_EQ(r.masks.at(1).data, (std::vector<std::uint8_t>{0, 1, 0}));
  // Stored 1 with slope 2: the label is 2. Big-endian int16 stored 1.
  write_bytes(dir.file("s.raw"), testing::payload(std::vector<std::int16_t>{0, 0, 1}, true));
  LabelVolume v = raw_volume(dir.file("s.raw"), g, ScalarType::i16);
  v.image.voxels.big_endian = true;
  v.image.voxels.slope = 2.0;
  r = read(v, g, classes_by_value(2), 2);
  EXPECT_EQ(r.masks.at(1).data, (std::vector<std::uint8_t>{0, 0, 1}));
}

TEST(LabelVolumeErrors, ValuesThatAreNotLabels) {
  TempDir dir;
  const Grid g = grid({3, 2, 1});
  write_bytes(dir.file("f.raw"), testing::payload(std::vector<float>{0, 1, 0, 0, 0.5f, 0}));
  EXPECT_PALP_ERROR(
      read(raw_volume(dir.file("f.raw"), g, ScalarType::f32), g, classes_by_value(1), 1),
      InputError, "f.raw: voxel (1, 1, 0) holds 0.5: not a label");
  write_bytes(dir.file("n.raw"), testing::payload(std::vector<std::int16_t>{0, -1, 0, 0, 0, 0}));
  EXPECT_PALP_ERROR(
      read(raw_volume(dir.file("n.raw"), g, ScalarType::i16), g, classes_by_value(1), 1),
      InputError, "voxel (1, 0, 0) holds -1: not a label");
  std::vector<std::uint8_t> big(24, 0);  // int32 70000 (0x11170) at voxel 2, little-endian
  big[8] = 0x70;
  big[9] = 0x11;
  big[10] = 0x01;
  write_bytes(dir.file("b.raw"), big);
  EXPECT_PALP_ERROR(
      read(raw_volume(dir.file("b.raw"), g, ScalarType::i32), g, classes_by_value(1), 1),
      InputError, "voxel (2, 0, 0) holds 70000: not a label");
  LabelVolume scaled = raw_volume(dir.file("b.raw"), g, ScalarType::i32);
  scaled.image.voxels.slope = 0.25;  // 70000 / 4 = 17500 is a label, but 0 * 0.25 + 0.5 is not
  scaled.image.voxels.intercept = 0.5;
  EXPECT_PALP_ERROR(read(scaled, g, classes_by_value(1), 1), InputError,
                    "voxel (0, 0, 0) holds 0.5: not a label");
  // Component 1 of voxel 3, (1, 0, 1), of a two-layer file.
  write_bytes(dir.file("l.raw"),
              testing::payload(std::vector<std::int16_t>{0, 0, 0, 0, 0, 0, 0, -7}));
  EXPECT_PALP_ERROR(read(raw_volume(dir.file("l.raw"), grid({2, 1, 2}), ScalarType::i16, 2),
                         grid({2, 1, 2}), LabelLookup{{{-1}, {-1}}}, 0),
                    InputError, "layer 1 of voxel (1, 0, 1) holds -7: not a label");
}

TEST(LabelVolumeErrors, NoOverlapIsRefusedBeforeReading) {
  TempDir dir;
  const Grid ct = grid({4, 4, 4});
  // 100 mm to the left of the CT; the file is too short, which is never reached.
  const Grid far = grid({4, 4, 4}, {1, 1, 1}, {100, 0, 0});
  write_bytes(dir.file("l.raw"), std::vector<std::uint8_t>{1});
  EXPECT_PALP_ERROR(
      read(raw_volume(dir.file("l.raw"), far, ScalarType::u8), ct, classes_by_value(1), 1),
      InputError,
      "l.raw does not overlap the CT (in the patient's LPS world the labels span "
      "[100, 103] x [0, 3] x [0, 3] mm, the CT [0, 3] x [0, 3] x [0, 3] mm)");
  // Half a voxel away still reaches the CT's last voxel.
  const Grid near = grid({4, 4, 4}, {1, 1, 1}, {3.4, 0, 0});
  write_bytes(dir.file("n.raw"), std::vector<std::uint8_t>(64, 1));
  const Read r =
      read(raw_volume(dir.file("n.raw"), near, ScalarType::u8), ct, classes_by_value(1), 1);
  EXPECT_EQ(r.counts.ct_covered, 16u);
  EXPECT_EQ(r.counts.on_ct[0], 16u);
  EXPECT_EQ(r.counts.in_file[0], 64u);
}

TEST(LabelVolumeErrors, LyingHeadersAndHugeSlices) {
  TempDir dir;
  const Grid ct = grid({4, 4, 4});
  write_bytes(dir.file("short.raw"), std::vector<std::uint8_t>(8, 0));
  EXPECT_PALP_ERROR(read(raw_volume(dir.file("short.raw"), grid({100, 100, 100}), ScalarType::i16),
                         ct, classes_by_value(1), 1),
                    InputError, "short.raw: header says 2000000 bytes of voxel data, file has 8");
  // A gzip stream of 64 zeros cannot decode to the 2 GB its header claims (deflate: <= 1032:1).
  const std::vector<std::uint8_t> zeros(64, 0);
  const std::vector<std::uint8_t> gz = gzip_compress(ByteSpan(zeros.data(), zeros.size()));
  write_bytes(dir.file("claim.gz"), gz);
  LabelVolume claim = raw_volume(dir.file("claim.gz"), grid({1024, 1024, 1024}), ScalarType::u16);
  claim.image.voxels.compression = Compression::gzip;
  EXPECT_PALP_ERROR(read(claim, ct, classes_by_value(1), 1), InputError,
                    "header says 2147483648 bytes of voxel data, file has " +
                        std::to_string(gz.size()) + " compressed bytes");
  // Within the ratio, but the stream ends early.
  LabelVolume cut = raw_volume(dir.file("claim.gz"), grid({8, 4, 4}), ScalarType::u8);
  cut.image.voxels.compression = Compression::gzip;
  EXPECT_PALP_ERROR(read(cut, ct, classes_by_value(1), 1), InputError,
                    "header says 128 bytes of voxel data, file has 64");
  // One slice beyond the slab: refused before anything is read.
  EXPECT_PALP_ERROR(read(raw_volume(dir.file("short.raw"), grid({8, 8, 1}), ScalarType::u8), ct,
                         classes_by_value(1), 1, 32),
                    InputError, "one slice holds 64 values (more than 32)");
}

TEST(LabelVolume, SameGridAndDescription) {
  const Grid a = grid({4, 3, 2}, {0.5, 0.5, 2}, {10, 20, 30});
  Grid b = a;
  b.world.origin[0] += 1e-5;  // float rounding of a copied header
  EXPECT_TRUE(same_grid(a, b));
  b.world.origin[0] += 0.1;
  EXPECT_FALSE(same_grid(a, b));
  EXPECT_EQ(describe_grid(a), "0.5 x 0.5 x 2 mm (4 x 3 x 2 voxels)");
}

}  // namespace
}  // namespace palp::labels
