// Tests for ct_io.hpp: input dispatch (phantom, directory, extensions in any case, missing and
// unsupported inputs) and the real abdominal CT from ../shared/data when it is present.
#include "io/ct_io.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <fstream>

#include "base/errors.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

using testing::TempDir;

CtVolume small_ct() {
  Grid g;
  g.dims = {4, 3, 2};
  g.spacing = {1.5, 1.5, 3};
  g.world.origin = {5, 6, 7};
  CtVolume ct(g);
  for (std::size_t n = 0; n < ct.size(); ++n)
    ct.data[n] = static_cast<std::int16_t>(100 * n - 1000);
  return ct;
}

TEST(CtIo, ExtensionsAreCaseInsensitive) {
  TempDir dir;
  const CtVolume ct = small_ct();
  for (const char* name : {"A.NII", "b.Nii.Gz"}) {
    write_nifti(dir.file(name), ct);
    EXPECT_EQ(read_ct(dir.file(name)).data, ct.data) << name;
  }
}

TEST(CtIo, VoxelFileIsTheDetachedDataFileOrTheFileItself) {
  TempDir dir;
  write_nifti(dir.file("a.nii.gz"), small_ct());
  EXPECT_EQ(ct_voxel_file(dir.file("a.nii.gz")), dir.file("a.nii.gz"));
  std::ofstream(dir.file("b.mhd")) << "ObjectType = Image\nNDims = 3\nDimSize = 2 2 2\n"
                                      "ElementSpacing = 1 1 1\nElementType = MET_SHORT\n"
                                      "ElementDataFile = b_voxels.raw\n";
  std::ofstream(dir.file("b_voxels.raw"), std::ios::binary) << std::string(16, '\0');
  EXPECT_EQ(ct_voxel_file(dir.file("b.mhd")), dir.file("b_voxels.raw"));
  EXPECT_THROW(ct_voxel_file(dir.file("c.unknown")), InputError);
}

TEST(CtIo, PhantomInputsGoToTheGenerator) {
  const CtVolume cube = read_ct("phantom:cube");
  EXPECT_GT(cube.size(), 0u);
  EXPECT_EQ(cube.size(), cube.grid.voxel_count());
  EXPECT_THROW(read_ct("phantom:no-such-phantom"), Error);
}

TEST(CtIo, MissingAndUnsupportedInputs) {
  EXPECT_PALP_ERROR(read_ct("/nonexistent/ct.nii.gz"), InputError,
                    "/nonexistent/ct.nii.gz: no such file or directory");
  EXPECT_PALP_ERROR(read_ct("/nonexistent/series"), InputError,
                    "/nonexistent/series: no such file or directory");
  TempDir dir;
  testing::write_text(dir.file("scan.png"), "png?");
  EXPECT_PALP_ERROR(
      read_ct(dir.file("scan.png")), InputError,
      "scan.png: unsupported input (expected a .nii, .nii.gz, .mha, .mhd, .nrrd or .nhdr file, "
      "a DICOM series directory, or phantom:NAME)");
  EXPECT_PALP_ERROR(read_ct(""), InputError, "no CT input given");
}

TEST(CtIo, UnreadableFile) {
  if (::geteuid() == 0) GTEST_SKIP() << "root reads any file";
  TempDir dir;
  write_nifti(dir.file("locked.nii"), small_ct());
  std::filesystem::permissions(dir.file("locked.nii"), std::filesystem::perms::none);
  EXPECT_PALP_ERROR(read_ct(dir.file("locked.nii")), InputError,
                    "locked.nii: cannot open (Permission denied)");
}

// Anything that is not a regular file is refused at once, never read forever: a FIFO named as
// the CT (opening it would wait for a writer), a detached header whose data file is /dev/zero,
// and a loop of symbolic links, named as such.
TEST(CtIo, NonRegularFilesAreRefusedWithoutBlocking) {
  TempDir dir;
  ASSERT_EQ(::mkfifo(dir.file("pipe.nii").c_str(), 0600), 0);
  EXPECT_PALP_ERROR(read_ct(dir.file("pipe.nii")), InputError,
                    "pipe.nii: a FIFO, not a regular file: palp reads files only");
  testing::write_text(dir.file("zero.mhd"),
                      "ObjectType = Image\nNDims = 3\nDimSize = 4 4 4\nElementType = MET_SHORT\n"
                      "ElementDataFile = /dev/zero\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("zero.mhd")), InputError,
                    "/dev/zero: a character device, not a regular file");
  std::filesystem::create_symlink(dir.file("b.nii"), dir.file("a.nii"));
  std::filesystem::create_symlink(dir.file("a.nii"), dir.file("b.nii"));
  EXPECT_PALP_ERROR(read_ct(dir.file("a.nii")), InputError, "a.nii: a loop of symbolic links");
}

TEST(CtIo, EmptyFiles) {
  TempDir dir;
  for (const char* name : {"e.nii", "e.nii.gz", "e.mha", "e.nrrd"}) {
    testing::write_text(dir.file(name), "");
    EXPECT_THROW(read_ct(dir.file(name)), InputError) << name;
  }
}

// ---- the real CT ----

const std::string kRealCt = std::string(PALP_SHARED_DATA_DIR) + "/ct_abdomen_3mm.nii.gz";

// The 348-byte header of a .nii.gz, read with zlib (independently of the code under test).
std::vector<std::uint8_t> gz_header(const std::string& path) {
  gzFile file = gzopen(path.c_str(), "rb");
  std::vector<std::uint8_t> header(348);
  EXPECT_EQ(gzread(file, header.data(), 348), 348);
  gzclose(file);
  return header;
}

std::array<float, 12> srows(const std::vector<std::uint8_t>& header) {
  std::array<float, 12> rows{};
  for (int n = 0; n < 12; ++n) rows[n] = testing::get<float>(header, 280 + 4 * n);
  return rows;
}

TEST(RealCt, ReadsTheAbdomenWithItsPlacement) {
  if (!std::filesystem::exists(kRealCt)) GTEST_SKIP() << kRealCt << " is absent";
  const CtVolume ct = read_ct(kRealCt);
  EXPECT_EQ(ct.grid.dims, (Index3{122, 101, 112}));
  EXPECT_EQ(ct.grid.spacing, (Vec3{3, 3, 3}));
  const auto [lo, hi] = std::minmax_element(ct.data.begin(), ct.data.end());
  EXPECT_LE(*lo, -1000);
  EXPECT_GE(*lo, -2048);
  EXPECT_GT(*hi, 1000);

  // The file's RAS sform, flipped in x and y, is the LPS placement.
  const auto header = gz_header(kRealCt);
  ASSERT_GT(testing::get<std::int16_t>(header, 254), 0);  // sform_code
  const auto s = srows(header);
  const double flip[3] = {-1, -1, 1};
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(ct.grid.world.origin[r], flip[r] * s[r * 4 + 3], 1e-4);
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(ct.grid.world.direction[r * 3 + c], flip[r] * s[r * 4 + c] / ct.grid.spacing[c],
                  1e-6);
  }
}

TEST(RealCt, WritingBackKeepsVoxelsAndAffine) {
  if (!std::filesystem::exists(kRealCt)) GTEST_SKIP() << kRealCt << " is absent";
  TempDir dir;
  const CtVolume ct = read_ct(kRealCt);
  write_nifti(dir.file("copy.nii.gz"), ct);
  const CtVolume back = read_ct(dir.file("copy.nii.gz"));
  EXPECT_EQ(back.grid, ct.grid);
  EXPECT_EQ(back.data, ct.data);
  const auto in = srows(gz_header(kRealCt));
  const auto out = srows(gz_header(dir.file("copy.nii.gz")));
  for (int n = 0; n < 12; ++n) EXPECT_NEAR(out[n], in[n], 1e-4) << "srow element " << n;
}

}  // namespace
}  // namespace palp
