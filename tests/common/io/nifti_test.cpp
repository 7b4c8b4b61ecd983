// Tests for nifti.hpp and the NIfTI paths of ct_io.hpp: writer/reader round trips (values, grid,
// world placement), headers built byte by byte here (both byte orders, datatypes, scaling,
// qform / sform / no transform), and every kind of bad file.
#include "io/nifti.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

using testing::get;
using testing::put;
using testing::read_bytes;
using testing::TempDir;
using testing::write_bytes;

// A small grid with anisotropic spacing and an axis-permuting, flipping direction (LPS).
Grid tilted_grid() {
  Grid g;
  g.dims = {5, 4, 3};
  g.spacing = {0.75, 1.25, 2.5};
  // i -> +y (posterior), j -> -x (right), k -> +z.
  g.world.direction = {0, -1, 0, 1, 0, 0, 0, 0, 1};
  g.world.origin = {-100.5, 20.25, 33.0};
  return g;
}

CtVolume sample_ct(const Grid& g) {
  CtVolume ct(g);
  for (std::size_t n = 0; n < ct.size(); ++n)
    ct.data[n] = static_cast<std::int16_t>(n * 37 % 3001 - 1024);
  ct.data[0] = std::numeric_limits<std::int16_t>::min();
  ct.data[1] = std::numeric_limits<std::int16_t>::max();
  return ct;
}

TEST(Nifti, CtRoundTripIsExactForNiiAndNiiGz) {
  TempDir dir;
  const CtVolume ct = sample_ct(tilted_grid());
  for (const char* name : {"ct.nii", "ct.nii.gz"}) {
    write_nifti(dir.file(name), ct);
    const CtVolume back = read_ct(dir.file(name));
    EXPECT_EQ(back.grid, ct.grid) << name;
    EXPECT_EQ(back.data, ct.data) << name;
  }
  EXPECT_TRUE(file_is_gzip(dir.file("ct.nii.gz")));
  EXPECT_FALSE(file_is_gzip(dir.file("ct.nii")));
}

TEST(Nifti, MaskAndFloatRoundTrips) {
  TempDir dir;
  Mask mask(tilted_grid());
  for (std::size_t n = 0; n < mask.size(); n += 3) mask.data[n] = 1;
  write_nifti(dir.file("m.nii.gz"), mask);
  const Mask mask_back = read_nifti_mask(dir.file("m.nii.gz"));
  EXPECT_EQ(mask_back.grid, mask.grid);
  EXPECT_EQ(mask_back.data, mask.data);

  DistanceMap d(tilted_grid());
  for (std::size_t n = 0; n < d.size(); ++n) d.data[n] = static_cast<float>(n) * 0.37f - 11.0f;
  d.data[2] = -1e30f;
  write_nifti(dir.file("d.nii.gz"), d);
  const DistanceMap d_back = read_nifti_float(dir.file("d.nii.gz"));
  EXPECT_EQ(d_back.grid, d.grid);
  EXPECT_EQ(d_back.data, d.data);
}

TEST(Nifti, ObliqueDirectionRoundTripsToFloatPrecision) {
  TempDir dir;
  Grid g = tilted_grid();
  const double a = 0.3;
  const double b = -0.2;
  // Rotation about z by a, then about x by b (columns are the axes).
  const double ca = std::cos(a), sa = std::sin(a), cb = std::cos(b), sb = std::sin(b);
  g.world.direction = {ca, -sa * cb, sa * sb, sa, ca * cb, -ca * sb, 0, sb, cb};
  write_nifti(dir.file("o.nii"), sample_ct(g));
  const CtVolume back = read_ct(dir.file("o.nii"));
  for (int n = 0; n < 9; ++n) EXPECT_NEAR(back.grid.world.direction[n], g.world.direction[n], 1e-6);
  for (int n = 0; n < 3; ++n) EXPECT_NEAR(back.grid.world.origin[n], g.world.origin[n], 1e-5);
}

TEST(Nifti, WrittenHeaderFieldsFollowTheStandard) {
  TempDir dir;
  const CtVolume ct = sample_ct(tilted_grid());
  write_nifti(dir.file("h.nii"), ct);
  const auto bytes = read_bytes(dir.file("h.nii"));
  ASSERT_EQ(bytes.size(), 352 + ct.size() * 2);
  EXPECT_EQ(get<std::int32_t>(bytes, 0), 348);
  EXPECT_EQ(get<std::int16_t>(bytes, 40), 3);    // dim[0]
  EXPECT_EQ(get<std::int16_t>(bytes, 42), 5);    // dim[1]
  EXPECT_EQ(get<std::int16_t>(bytes, 70), 4);    // datatype int16
  EXPECT_EQ(get<std::int16_t>(bytes, 72), 16);   // bitpix
  EXPECT_EQ(get<float>(bytes, 80), 0.75f);       // pixdim[1]
  EXPECT_EQ(get<float>(bytes, 108), 352.0f);     // vox_offset
  EXPECT_EQ(get<float>(bytes, 112), 1.0f);       // scl_slope
  EXPECT_EQ(bytes[123], 2);                      // xyzt_units: mm
  EXPECT_EQ(get<float>(bytes, 124), 32767.0f);   // cal_max
  EXPECT_EQ(get<float>(bytes, 128), -32768.0f);  // cal_min
  EXPECT_EQ(get<std::int16_t>(bytes, 252), 1);   // qform_code
  EXPECT_EQ(get<std::int16_t>(bytes, 254), 1);   // sform_code
  // sform row x (RAS): LPS column i = (0,1,0) -> RAS (0,-1,0); column j = (-1,0,0) -> (1,0,0).
  EXPECT_EQ(get<float>(bytes, 280), 0.0f);
  EXPECT_EQ(get<float>(bytes, 284), 1.25f);
  EXPECT_EQ(get<float>(bytes, 292), 100.5f);  // -origin x
  EXPECT_EQ(get<float>(bytes, 296), -0.75f);  // srow_y[0]
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(&bytes[344])), "n+1");
}

TEST(Nifti, QformAloneGivesTheSamePlacementAsSform) {
  TempDir dir;
  const CtVolume ct = sample_ct(tilted_grid());
  write_nifti(dir.file("q.nii"), ct);
  auto bytes = read_bytes(dir.file("q.nii"));
  put<std::int16_t>(bytes, 254, 0);  // sform_code = 0: the reader must use the quaternion
  write_bytes(dir.file("q.nii"), bytes);
  const CtVolume back = read_ct(dir.file("q.nii"));
  for (int n = 0; n < 9; ++n)
    EXPECT_NEAR(back.grid.world.direction[n], ct.grid.world.direction[n], 1e-7);
  EXPECT_EQ(back.grid.world.origin, ct.grid.world.origin);
}

// ---- headers built here, independently of the writer ----

struct NiftiSpec {
  std::array<std::int16_t, 8> dim{3, 3, 2, 2, 1, 1, 1, 1};
  std::int16_t datatype = 4;
  std::int16_t bitpix = 16;
  std::array<float, 8> pixdim{1, 2, 3, 4, 1, 1, 1, 1};
  float vox_offset = 352;
  float slope = 1;
  float inter = 0;
  std::int16_t qform_code = 0;
  std::int16_t sform_code = 0;
  std::array<float, 3> quatern{0, 0, 0};
  std::array<float, 3> qoffset{0, 0, 0};
  std::array<float, 12> srow{};
  std::int32_t sizeof_hdr = 348;
  std::string magic = "n+1";
};

std::vector<std::uint8_t> header_bytes(const NiftiSpec& s, bool big) {
  std::vector<std::uint8_t> h(static_cast<std::size_t>(s.vox_offset > 348 ? s.vox_offset : 352), 0);
  put(h, 0, s.sizeof_hdr, big);
  for (int n = 0; n < 8; ++n) put(h, 40 + 2 * n, s.dim[n], big);
  put(h, 70, s.datatype, big);
  put(h, 72, s.bitpix, big);
  for (int n = 0; n < 8; ++n) put(h, 76 + 4 * n, s.pixdim[n], big);
  put(h, 108, s.vox_offset, big);
  put(h, 112, s.slope, big);
  put(h, 116, s.inter, big);
  put(h, 252, s.qform_code, big);
  put(h, 254, s.sform_code, big);
  for (int n = 0; n < 3; ++n) put(h, 256 + 4 * n, s.quatern[n], big);
  for (int n = 0; n < 3; ++n) put(h, 268 + 4 * n, s.qoffset[n], big);
  for (int n = 0; n < 12; ++n) put(h, 280 + 4 * n, s.srow[n], big);
  std::memcpy(&h[344], s.magic.c_str(), std::min<std::size_t>(4, s.magic.size() + 1));
  return h;
}

template <class T>
std::vector<std::uint8_t> nifti_file(const NiftiSpec& s, const std::vector<T>& values, bool big) {
  auto bytes = header_bytes(s, big);
  for (const T v : values) testing::append(bytes, v, big);
  return bytes;
}

TEST(Nifti, ReadsBothByteOrders) {
  TempDir dir;
  const std::vector<std::int16_t> values{-1024, -1000, 0, 1, 2, 3, 40, 500, 1000, 2000, 3000, -5};
  for (const bool big : {false, true}) {
    const std::string path = dir.file(big ? "big.nii" : "little.nii");
    write_bytes(path, nifti_file(NiftiSpec{}, values, big));
    const CtVolume ct = read_ct(path);
    EXPECT_EQ(ct.grid.dims, (Index3{3, 2, 2}));
    EXPECT_EQ(ct.grid.spacing, (Vec3{2, 3, 4}));
    EXPECT_EQ(ct.data, values) << path;
  }
}

TEST(Nifti, AppliesSlopeAndInterceptAndRoundsFloats) {
  TempDir dir;
  NiftiSpec s;
  s.datatype = 512;  // uint16
  s.slope = 1;
  s.inter = -1024;
  const std::vector<std::uint16_t> stored{0, 24, 1024, 1064, 4000, 65535, 1, 2, 3, 4, 5, 6};
  write_bytes(dir.file("u16.nii"), nifti_file(s, stored, false));
  const CtVolume ct = read_ct(dir.file("u16.nii"));
  EXPECT_EQ(ct.data[0], -1024);
  EXPECT_EQ(ct.data[2], 0);
  EXPECT_EQ(ct.data[3], 40);
  EXPECT_EQ(ct.data[5], 32767);  // 64511 saturates

  s.datatype = 16;  // float32 with slope 2
  s.bitpix = 32;
  s.slope = 2;
  s.inter = 0.5f;
  const std::vector<float> f{-600.0f, 0.2f, 10.6f, -0.6f, 1e9f, -1e9f, NAN, 0, 0, 0, 0, 0};
  write_bytes(dir.file("f.nii.gz"), gzip_compress(ByteSpan(nifti_file(s, f, true))));
  const CtVolume g = read_ct(dir.file("f.nii.gz"));
  EXPECT_EQ(g.data[0], -1200);  // -1199.5 rounds away from zero
  EXPECT_EQ(g.data[1], 1);      // 0.9
  EXPECT_EQ(g.data[2], 22);     // 21.7
  EXPECT_EQ(g.data[3], -1);     // -0.7
  EXPECT_EQ(g.data[4], 32767);
  EXPECT_EQ(g.data[5], -32768);
  EXPECT_EQ(g.data[6], -1024);  // NaN reads as air
  const DistanceMap fl = read_nifti_float(dir.file("f.nii.gz"));
  EXPECT_FLOAT_EQ(fl.data[2], 21.7f);

  s.slope = 0;  // slope 0 means "no scaling"
  write_bytes(dir.file("s0.nii"), nifti_file(s, f, false));
  EXPECT_EQ(read_ct(dir.file("s0.nii")).data[0], -600);
}

TEST(Nifti, ReadsEveryIntegerDatatype) {
  TempDir dir;
  auto check = [&](auto sample, std::int16_t code, const char* name) {
    using T = decltype(sample);
    NiftiSpec s;
    s.datatype = code;
    s.bitpix = static_cast<std::int16_t>(8 * sizeof(T));
    std::vector<T> values(12);
    for (int n = 0; n < 12; ++n) values[n] = static_cast<T>(n * 10);
    values[11] = sample;
    write_bytes(dir.file(name), nifti_file(s, values, false));
    const CtVolume ct = read_ct(dir.file(name));
    EXPECT_EQ(ct.data[3], 30) << name;
    return ct.data[11];
  };
  EXPECT_EQ(check(std::uint8_t{255}, 2, "u8.nii"), 255);
  EXPECT_EQ(check(std::int8_t{-100}, 256, "i8.nii"), -100);
  EXPECT_EQ(check(std::int32_t{-70000}, 8, "i32.nii"), -32768);
  EXPECT_EQ(check(std::uint32_t{70000}, 768, "u32.nii"), 32767);
  EXPECT_EQ(check(std::int64_t{-1024}, 1024, "i64.nii"), -1024);
  EXPECT_EQ(check(double{-3.5}, 64, "f64.nii"), -4);
}

TEST(Nifti, QuaternionAndFallbackPlacements) {
  TempDir dir;
  const std::vector<std::int16_t> values(12, 7);
  NiftiSpec s;
  s.qform_code = 1;
  s.quatern = {0, 0, static_cast<float>(std::sqrt(0.5))};  // 90 degrees about z
  s.qoffset = {10, 20, 30};
  write_bytes(dir.file("q.nii"), nifti_file(s, values, false));
  const WorldPlacement q = read_ct(dir.file("q.nii")).grid.world;
  // RAS rotation columns i -> (0,1,0), j -> (-1,0,0); in LPS: i -> (0,-1,0), j -> (1,0,0).
  const std::array<double, 9> expected{0, 1, 0, -1, 0, 0, 0, 0, 1};
  for (int n = 0; n < 9; ++n) EXPECT_NEAR(q.direction[n], expected[n], 1e-6);
  EXPECT_EQ(q.origin, (Vec3{-10, -20, 30}));

  s.pixdim[0] = -1;  // qfac -1 flips k
  write_bytes(dir.file("qfac.nii"), nifti_file(s, values, false));
  EXPECT_NEAR(read_ct(dir.file("qfac.nii")).grid.world.direction[8], -1.0, 1e-7);

  s.qform_code = 0;  // neither: scaled identity in RAS, i.e. x and y flipped in LPS
  write_bytes(dir.file("none.nii"), nifti_file(s, values, false));
  const WorldPlacement none = read_ct(dir.file("none.nii")).grid.world;
  EXPECT_EQ(none.direction, (std::array<double, 9>{-1, 0, 0, 0, -1, 0, 0, 0, 1}));
  EXPECT_EQ(none.origin, (Vec3{0, 0, 0}));
}

TEST(Nifti, FourDimensionalWithOneVolumeAndVoxOffset) {
  TempDir dir;
  NiftiSpec s;
  s.dim = {4, 3, 2, 2, 1, 1, 1, 1};
  s.vox_offset = 400;
  const std::vector<std::int16_t> values{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  write_bytes(dir.file("4d.nii"), nifti_file(s, values, false));
  EXPECT_EQ(read_ct(dir.file("4d.nii")).data, values);

  s.dim[4] = 2;
  write_bytes(dir.file("4d2.nii"), nifti_file(s, values, false));
  EXPECT_PALP_ERROR(read_ct(dir.file("4d2.nii")), InputError, "dim[4] = 2");
}

// ---- bad input ----

TEST(NiftiErrors, FileShorterThanTheHeaderSays) {
  TempDir dir;
  const std::vector<std::int16_t> values(5, 1);  // 12 voxels needed
  write_bytes(dir.file("short.nii"), nifti_file(NiftiSpec{}, values, false));
  EXPECT_PALP_ERROR(read_ct(dir.file("short.nii")), InputError,
                    "short.nii: header says 24 bytes of voxel data, file has 10");
  write_bytes(dir.file("short.nii.gz"),
              gzip_compress(ByteSpan(nifti_file(NiftiSpec{}, values, false))));
  EXPECT_PALP_ERROR(read_ct(dir.file("short.nii.gz")), InputError,
                    "short.nii.gz: header says 24 bytes of voxel data, file has 10");
}

// 3 MB of incompressible voxels behind a header claiming 1000^3 int16 (2 GB): within deflate's
// ratio of the compressed size, so only decoding shows the lie; the volume must grow with the
// bytes that arrive instead of being allocated for the claim.
TEST(NiftiErrors, CompressedClaimBeyondItsStreamCostsOnlyWhatTheStreamHolds) {
  TempDir dir;
  std::vector<std::int16_t> values(1500000);
  std::uint32_t state = 12345;
  for (auto& v : values) {
    state = state * 1664525u + 1013904223u;
    v = static_cast<std::int16_t>(state >> 16);
  }
  NiftiSpec s;
  s.dim = {3, 1000, 1000, 1000, 1, 1, 1, 1};
  write_bytes(dir.file("liar.nii.gz"), gzip_compress(ByteSpan(nifti_file(s, values, false))));
  values = {};
  testing::reset_peak_memory();
  const std::size_t before = testing::peak_memory_bytes();
  EXPECT_PALP_ERROR(read_ct(dir.file("liar.nii.gz")), InputError,
                    "liar.nii.gz: header says 2000000000 bytes of voxel data, file has 3000000");
  EXPECT_LT(testing::peak_memory_bytes(), before + (128u << 20));
}

TEST(NiftiErrors, TruncatedAndCorruptGzip) {
  TempDir dir;
  write_nifti(dir.file("ok.nii.gz"), sample_ct(tilted_grid()));
  auto bytes = read_bytes(dir.file("ok.nii.gz"));
  write_bytes(dir.file("cut.nii.gz"),
              std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 200));
  EXPECT_PALP_ERROR(
      read_ct(dir.file("cut.nii.gz")), InputError,
      "cut.nii.gz: truncated gzip stream (file ends before the compressed data does)");
  bytes[bytes.size() - 5] ^= 0xff;  // the data's length check in the trailer
  write_bytes(dir.file("bad.nii.gz"), bytes);
  EXPECT_PALP_ERROR(read_ct(dir.file("bad.nii.gz")), InputError, "bad.nii.gz: corrupt gzip data");
}

TEST(NiftiErrors, AbsurdAndZeroDimensions) {
  TempDir dir;
  const std::vector<std::int16_t> values(12, 1);
  NiftiSpec s;
  s.dim = {3, 16000, 16000, 16000, 1, 1, 1, 1};
  write_bytes(dir.file("huge.nii"), nifti_file(s, values, false));
  EXPECT_PALP_ERROR(read_ct(dir.file("huge.nii")), InputError, "header says 8192000000000 bytes");
  write_bytes(dir.file("huge.nii.gz"), gzip_compress(ByteSpan(nifti_file(s, values, false))));
  EXPECT_PALP_ERROR(read_ct(dir.file("huge.nii.gz")), InputError, "compressed bytes");
  s.dim = {3, 3, 0, 2, 1, 1, 1, 1};
  write_bytes(dir.file("zero.nii"), nifti_file(s, values, false));
  EXPECT_PALP_ERROR(read_ct(dir.file("zero.nii")), InputError, "dimensions 3x0x2 are not usable");
  s.dim = {3, -3, 2, 2, 1, 1, 1, 1};
  write_bytes(dir.file("neg.nii"), nifti_file(s, values, false));
  EXPECT_PALP_ERROR(read_ct(dir.file("neg.nii")), InputError, "not usable");
  s.dim = {0, 3, 2, 2, 1, 1, 1, 1};
  write_bytes(dir.file("dim0.nii"), nifti_file(s, values, false));
  EXPECT_PALP_ERROR(read_ct(dir.file("dim0.nii")), InputError, "dim[0] is 0");
}

TEST(NiftiErrors, NonFiniteSpacing) {
  TempDir dir;
  NiftiSpec s;
  s.pixdim[2] = NAN;
  write_bytes(dir.file("nan.nii"), nifti_file(s, std::vector<std::int16_t>(12, 1), false));
  EXPECT_PALP_ERROR(read_ct(dir.file("nan.nii")), InputError, "nan.nii: spacing");
  s.pixdim[2] = 0;
  write_bytes(dir.file("zero.nii"), nifti_file(s, std::vector<std::int16_t>(12, 1), false));
  EXPECT_PALP_ERROR(read_ct(dir.file("zero.nii")), InputError, "zero.nii: spacing");
}

TEST(NiftiErrors, UnsupportedDatatypeAndNotNifti) {
  TempDir dir;
  NiftiSpec s;
  s.datatype = 32;  // complex64
  write_bytes(dir.file("c.nii"), nifti_file(s, std::vector<std::int16_t>(48, 1), false));
  EXPECT_PALP_ERROR(read_ct(dir.file("c.nii")), InputError,
                    "NIfTI datatype 32 (complex64) is not supported");

  testing::write_text(dir.file("text.nii"), "hello, this is not an image\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("text.nii")), InputError, "text.nii: not a NIfTI-1 file");

  std::vector<std::uint8_t> big_text(400, 'x');
  write_bytes(dir.file("x.nii"), big_text);
  EXPECT_PALP_ERROR(read_ct(dir.file("x.nii")), InputError,
                    "x.nii: not a NIfTI-1 file (sizeof_hdr");

  s = NiftiSpec{};
  s.sizeof_hdr = 540;
  write_bytes(dir.file("two.nii"), nifti_file(s, std::vector<std::int16_t>(12, 1), false));
  EXPECT_PALP_ERROR(read_ct(dir.file("two.nii")), InputError, "NIfTI-2 files are not supported");

  s = NiftiSpec{};
  s.magic = "ni1";
  write_bytes(dir.file("pair.nii"), nifti_file(s, std::vector<std::int16_t>(12, 1), false));
  EXPECT_PALP_ERROR(read_ct(dir.file("pair.nii")), InputError, ".hdr/.img");

  s.magic = "abc";
  write_bytes(dir.file("magic.nii"), nifti_file(s, std::vector<std::int16_t>(12, 1), false));
  EXPECT_PALP_ERROR(read_ct(dir.file("magic.nii")), InputError, "magic");
}

TEST(NiftiErrors, MissingFileForEveryReader) {
  EXPECT_PALP_ERROR(read_nifti_float("/nonexistent/a.nii.gz"), InputError,
                    "/nonexistent/a.nii.gz: no such file or directory");
  EXPECT_PALP_ERROR(read_nifti_mask("/nonexistent/b.nii"), InputError,
                    "/nonexistent/b.nii: no such file or directory");
}

}  // namespace
}  // namespace palp
