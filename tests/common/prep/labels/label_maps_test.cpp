// Tests for label_maps.hpp: which format an input is, the refusals every format shares (a missing
// or unknown input, a lying header, absurd dims, values that are not labels), and the memory a
// label map larger than the CT costs: its masks on the CT's grid and one bounded slab, never the
// whole map.
#include "prep/labels/label_maps.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>

#include "base/errors.hpp"
#include "io/gzip.hpp"
#include "io/nifti.hpp"
#include "support/io_test_util.hpp"
#include "support/label_files.hpp"

namespace palp {
namespace {

using testing::label_grid;
using testing::read_bytes;
using testing::TempDir;
using testing::write_bytes;
using testing::write_label_nifti;

const Grid kCt = label_grid({4, 4, 4});

TEST(LabelMaps, InputsThatAreNoLabelMap) {
  TempDir dir;
  EXPECT_PALP_ERROR(read_label_maps(dir.file("gone.nii.gz"), kCt), InputError,
                    "labels: " + dir.file("gone.nii.gz") + ": no such file or directory");
  testing::write_text(dir.file("seg.txt"), "liver");
  EXPECT_PALP_ERROR(read_label_maps(dir.file("seg.txt"), kCt), InputError,
                    "seg.txt: not a label map palp reads");
  testing::write_text(dir.file("bad.nii"), "not a nifti");
  EXPECT_PALP_ERROR(read_label_maps(dir.file("bad.nii"), kCt), InputError,
                    "labels: " + dir.file("bad.nii") + ": not a NIfTI-1 file");
}

TEST(LabelMaps, LyingHeadersAndAbsurdDims) {
  TempDir dir;
  write_label_nifti(dir.file("l.nii"), kCt, std::vector<std::uint8_t>(64, 5));
  std::vector<std::uint8_t> bytes = read_bytes(dir.file("l.nii"));
  bytes.resize(bytes.size() - 4);  // 60 of the 64 voxels
  write_bytes(dir.file("short.nii"), bytes);
  EXPECT_PALP_ERROR(
      read_label_maps(dir.file("short.nii"), kCt, {kTotalSegmentatorMap}), InputError,
      "labels: " + dir.file("short.nii") + ": header says 64 bytes of voxel data, file has 60");
  const std::int16_t huge = 20000;  // dim[1], at byte 42
  std::memcpy(bytes.data() + 42, &huge, 2);
  write_bytes(dir.file("huge.nii"), bytes);
  EXPECT_PALP_ERROR(read_label_maps(dir.file("huge.nii"), kCt, {kTotalSegmentatorMap}), InputError,
                    "huge.nii: dimensions 20000x4x4 are not usable");
}

TEST(LabelMaps, NonIntegerLabelsAreRefused) {
  TempDir dir;
  std::vector<float> values(64, 0.0f);
  values[kCt.linear(1, 2, 3)] = 5.5f;
  write_nifti_file(dir.file("f.nii.gz"), kCt, ScalarType::f32,
                   ByteSpan(reinterpret_cast<const std::uint8_t*>(values.data()), 64 * 4), 0, 6);
  EXPECT_PALP_ERROR(read_label_maps(dir.file("f.nii.gz"), kCt, {kTotalSegmentatorMap}), InputError,
                    "f.nii.gz: voxel (1, 2, 3) holds 5.5: not a label");
  values[kCt.linear(1, 2, 3)] = 5.0f;  // float storage of whole numbers is fine
  write_nifti_file(dir.file("w.nii.gz"), kCt, ScalarType::f32,
                   ByteSpan(reinterpret_cast<const std::uint8_t*>(values.data()), 64 * 4), 0, 6);
  const LabelMaps maps = read_label_maps(dir.file("w.nii.gz"), kCt, {kTotalSegmentatorMap});
  ASSERT_EQ(maps.organs.size(), 1u);
  EXPECT_EQ(maps.organs[0].name, "liver");
}

// A 0.5 mm label map of 1024 x 1024 x 128 voxels (128 MiB as uint8, 256 MiB as labels) over a
// coarse 8 mm CT of 64 x 64 x 16. Written as gzip members of one slice each (a valid gzip file),
// so the test itself never holds it. Slice 64 labels liver (5) on its first 512 rows: CT voxel
// (i, j, k) at 8 (i, j, k) mm is nearest to label voxel 16 (i, j, k), so the liver is CT voxels
// j < 32 of slice k = 4; CT slices k >= 8 lie past the map.
TEST(LabelMaps, LargerMapCostsOneSlabNotItsSize) {
  TempDir dir;
  const Grid labels = label_grid({1024, 1024, 1}, {0.5, 0.5, 0.5}, {0, 0, 0});
  std::vector<std::uint8_t> slice(1024 * 1024, 0);
  write_label_nifti(dir.file("one.nii"), labels, slice);
  std::vector<std::uint8_t> header = read_bytes(dir.file("one.nii"));
  header.resize(352);
  const std::int16_t slices = 128;  // dim[3], at byte 46
  std::memcpy(header.data() + 46, &slices, 2);
  const std::vector<std::uint8_t> zeros = gzip_compress(ByteSpan(slice.data(), slice.size()));
  std::fill(slice.begin(), slice.begin() + 512 * 1024, 5);
  const std::vector<std::uint8_t> liver = gzip_compress(ByteSpan(slice.data(), slice.size()));
  std::vector<std::uint8_t> file = gzip_compress(ByteSpan(header.data(), header.size()));
  for (int k = 0; k < 128; ++k) {
    const auto& member = k == 64 ? liver : zeros;
    file.insert(file.end(), member.begin(), member.end());
  }
  write_bytes(dir.file("big.nii.gz"), file);
  slice = {};

  const Grid ct = label_grid({64, 64, 16}, {8, 8, 8}, {0, 0, 0});
  testing::reset_peak_memory();
  const std::size_t before = testing::peak_memory_bytes();  // the resident set now
  const LabelMaps maps = read_label_maps(dir.file("big.nii.gz"), ct, {kTotalSegmentatorMap});
  const std::size_t gained = testing::peak_memory_bytes() - before;
  ASSERT_EQ(maps.organs.size(), 1u);
  Mask expected(ct);
  for (std::int64_t j = 0; j < 32; ++j)
    for (std::int64_t i = 0; i < 64; ++i) expected.at(i, j, 4) = 1;
  EXPECT_EQ(on_ct_grid(maps.organs[0], ct).data, expected.data);
  // One slab (64 MiB) and the 1 MiB read buffer, well under the map's 128 MiB as bytes.
  if (before > 0) {
    EXPECT_LT(gained, std::size_t{100} << 20);
  }
  std::printf("read %.0f MiB of labels gaining %.1f MiB resident\n", 128.0,
              static_cast<double>(gained) / (1 << 20));
  ASSERT_EQ(maps.notes.size(), 1u);
  EXPECT_NE(maps.notes[0].find("resampled nearest-neighbour from 0.5 x 0.5 x 0.5 mm (1024 x "
                               "1024 x 128 voxels)"),
            std::string::npos);
}

}  // namespace
}  // namespace palp
