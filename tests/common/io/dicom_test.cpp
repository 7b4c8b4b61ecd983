// Tests for dicom.hpp: small CT series written here with GDCM (slices in shuffled file order,
// oblique orientation), transcoded to JPEG 2000 / JPEG lossless / JPEG-LS / RLE, which must all
// load to the same HU volume and geometry; and series that must be refused.
#include "io/dicom.hpp"

#include <gdcmAttribute.h>
#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gdcmTrace.h>
#include <gdcmUIDGenerator.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "io/dicom_layout.hpp"
#include "support/dicom_slice_writer.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

using testing::TempDir;

struct SeriesSpec {
  unsigned columns = 16;
  unsigned rows = 12;
  int slices = 8;
  double column_spacing = 0.75;  // along a row, between columns (x of the image)
  double row_spacing = 0.5;      // between rows
  double gap = 2.5;
  // Row direction (1,0,0), column direction (0,0.6,-0.8): normal (0,0.8,0.6).
  std::array<double, 6> orientation{1, 0, 0, 0, 0.6, -0.8};
  Vec3 origin{-40.0, 12.5, 100.0};
  double intercept = -1024.0;
  double slope = 1.0;
  bool unsigned_pixels = false;
  std::string series_uid = "1.2.826.0.1.3680043.2.1125.1.1";
};

constexpr std::array<double, 3> kNormal{0, 0.8, 0.6};

// The HU the test series holds at (i, j, k): a pattern with values from -1500 to 1499.
std::int16_t expected_hu(unsigned i, unsigned j, int k) {
  return static_cast<std::int16_t>((i * 7 + j * 131 + static_cast<unsigned>(k) * 1013) % 3000) -
         1500;
}

// Writes slice k of the series; `position_shift` moves it along the normal (mm).
void write_slice(const std::string& path, const SeriesSpec& spec, int k,
                 double position_shift = 0.0) {
  gdcm::Trace::WarningOff();  // GDCM notes that the new dataset has no PhotometricInterpretation
                              // yet
  gdcm::ImageWriter writer;
  gdcm::Image& image = writer.GetImage();
  image.SetNumberOfDimensions(2);
  image.SetDimension(0, spec.columns);
  image.SetDimension(1, spec.rows);
  image.SetPixelFormat(spec.unsigned_pixels ? gdcm::PixelFormat::UINT16 : gdcm::PixelFormat::INT16);
  image.SetPhotometricInterpretation(gdcm::PhotometricInterpretation::MONOCHROME2);
  image.SetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
  image.SetSpacing(0, spec.column_spacing);
  image.SetSpacing(1, spec.row_spacing);
  const double along = k * spec.gap + position_shift;
  // SetOrigin(const double*) copies only NumberOfDimensions (2) values: set all three.
  for (unsigned a = 0; a < 3; ++a) image.SetOrigin(a, spec.origin[a] + along * kNormal[a]);
  image.SetDirectionCosines(spec.orientation.data());
  image.SetIntercept(spec.intercept);
  image.SetSlope(spec.slope);

  std::vector<std::int16_t> pixels(spec.columns * spec.rows);
  for (unsigned j = 0; j < spec.rows; ++j)
    for (unsigned i = 0; i < spec.columns; ++i)
      pixels[j * spec.columns + i] = static_cast<std::int16_t>(
          std::lround((expected_hu(i, j, k) - spec.intercept) / spec.slope));
  testing::set_int16_pixels(image, pixels);

  gdcm::DataSet& ds = writer.GetFile().GetDataSet();
  testing::set_ct_slice_identity(ds, "1.2.826.0.1.3680043.2.1125.1", spec.series_uid, k + 1);
  writer.SetFileName(path.c_str());
  ASSERT_TRUE(writer.Write()) << path;
}

// Slice k goes to a file whose name does not sort in position order.
std::string slice_name(int k, int slices) {
  return "im" + std::to_string((k * 5 + 3) % slices) + ".dcm";
}

void write_series(const std::filesystem::path& dir, const SeriesSpec& spec) {
  std::filesystem::create_directories(dir);
  for (int k = 0; k < spec.slices; ++k)
    write_slice((dir / slice_name(k, spec.slices)).string(), spec, k);
}

void expect_series_volume(const CtVolume& ct, const SeriesSpec& spec) {
  ASSERT_EQ(ct.grid.dims, (Index3{spec.columns, spec.rows, spec.slices}));
  EXPECT_NEAR(ct.grid.spacing[0], spec.column_spacing, 1e-9);
  EXPECT_NEAR(ct.grid.spacing[1], spec.row_spacing, 1e-9);
  EXPECT_NEAR(ct.grid.spacing[2], spec.gap, 1e-6);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(ct.grid.world.origin[a], spec.origin[a], 1e-6);
  const std::array<double, 9> direction{1, 0, 0, 0, 0.6, 0.8, 0, -0.8, 0.6};
  for (int n = 0; n < 9; ++n) EXPECT_NEAR(ct.grid.world.direction[n], direction[n], 1e-9);
  int wrong = 0;
  for (int k = 0; k < spec.slices; ++k)
    for (unsigned j = 0; j < spec.rows; ++j)
      for (unsigned i = 0; i < spec.columns; ++i) wrong += ct.at(i, j, k) != expected_hu(i, j, k);
  EXPECT_EQ(wrong, 0);
}

// Copies every file of `from` into `to`, re-encoded with transfer syntax `ts`.
void transcode_series(const std::filesystem::path& from, const std::filesystem::path& to,
                      gdcm::TransferSyntax::TSType ts) {
  std::filesystem::create_directories(to);
  for (const auto& entry : std::filesystem::directory_iterator(from)) {
    gdcm::ImageReader reader;
    reader.SetFileName(entry.path().c_str());
    ASSERT_TRUE(reader.Read());
    gdcm::ImageChangeTransferSyntax change;
    change.SetTransferSyntax(ts);
    change.SetInput(reader.GetImage());
    ASSERT_TRUE(change.Change()) << gdcm::TransferSyntax::GetTSString(ts);
    gdcm::ImageWriter writer;
    writer.SetFileName((to / entry.path().filename()).c_str());
    writer.SetFile(reader.GetFile());
    writer.SetImage(change.GetOutput());
    ASSERT_TRUE(writer.Write());
  }
  // The copies really use the new transfer syntax.
  gdcm::ImageReader check;
  check.SetFileName((to / slice_name(0, 8)).c_str());
  ASSERT_TRUE(check.Read());
  EXPECT_EQ(check.GetFile().GetHeader().GetDataSetTransferSyntax(), gdcm::TransferSyntax(ts));
}

TEST(Dicom, UncompressedSeriesSortedByPositionNotFileName) {
  TempDir dir;
  const SeriesSpec spec;
  write_series(dir.path() / "ct", spec);
  testing::write_text(dir.file("ct/README.txt"), "not a DICOM file\n");  // skipped
  const CtVolume ct = read_dicom_series(dir.file("ct"));
  expect_series_volume(ct, spec);
  // read_ct dispatches directories to the DICOM reader.
  EXPECT_EQ(read_ct(dir.file("ct")).data, ct.data);
}

TEST(Dicom, PixelSpacingTagIsRowSpacingThenColumnSpacing) {
  TempDir dir;
  const SeriesSpec spec;
  write_slice(dir.file("one.dcm"), spec, 0);
  gdcm::ImageReader reader;
  reader.SetFileName(dir.file("one.dcm").c_str());
  ASSERT_TRUE(reader.Read());
  gdcm::Attribute<0x0028, 0x0030> spacing;
  spacing.SetFromDataSet(reader.GetFile().GetDataSet());
  EXPECT_DOUBLE_EQ(spacing.GetValue(0), spec.row_spacing);
  EXPECT_DOUBLE_EQ(spacing.GetValue(1), spec.column_spacing);
}

TEST(Dicom, CompressedTransferSyntaxesLoadToTheSameVolume) {
  TempDir dir;
  const SeriesSpec spec;
  write_series(dir.path() / "raw", spec);
  const CtVolume reference = read_dicom_series(dir.file("raw"));
  expect_series_volume(reference, spec);
  const std::pair<const char*, gdcm::TransferSyntax::TSType> syntaxes[] = {
      {"j2k", gdcm::TransferSyntax::JPEG2000Lossless},
      {"jpeg", gdcm::TransferSyntax::JPEGLosslessProcess14_1},
      {"jpegls", gdcm::TransferSyntax::JPEGLSLossless},
      {"rle", gdcm::TransferSyntax::RLELossless},
  };
  for (const auto& [name, ts] : syntaxes) {
    SCOPED_TRACE(name);
    transcode_series(dir.path() / "raw", dir.path() / name, ts);
    const CtVolume ct = read_dicom_series(dir.file(name));
    EXPECT_EQ(ct.grid, reference.grid);
    EXPECT_EQ(ct.data, reference.data);
  }
}

TEST(Dicom, UnsignedPixelsWithPerSliceRescale) {
  TempDir dir;
  SeriesSpec spec;
  spec.unsigned_pixels = true;
  spec.slope = 0.5;
  spec.intercept = -1600;
  write_series(dir.path() / "u", spec);
  expect_series_volume(read_dicom_series(dir.file("u")), spec);

  // A different intercept on one slice is applied to that slice only.
  SeriesSpec other = spec;
  other.intercept = -1700;
  write_slice(dir.file("u/" + slice_name(3, 8)), other, 3);
  expect_series_volume(read_dicom_series(dir.file("u")), spec);
}

TEST(Dicom, SeriesInASubdirectory) {
  TempDir dir;
  const SeriesSpec spec;
  write_series(dir.path() / "patient" / "series1", spec);
  expect_series_volume(read_ct(dir.file("patient")), spec);
}

// ---- refused series ----

TEST(DicomErrors, EmptyDirectory) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "empty");
  EXPECT_PALP_ERROR(read_ct(dir.file("empty")), InputError, "empty: directory is empty");
}

TEST(DicomErrors, DirectoryWithoutDicomFiles) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "text");
  for (const char* name : {"a.txt", "b.dcm", "c"})
    testing::write_text(dir.file(std::string("text/") + name), "hello\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("text")), InputError, "text: no DICOM images among 3 files");
}

TEST(DicomErrors, MixedSeries) {
  TempDir dir;
  SeriesSpec a;
  a.slices = 4;
  write_series(dir.path() / "mix", a);
  SeriesSpec b = a;
  b.series_uid = "1.2.826.0.1.3680043.2.1125.1.2";
  for (int k = 0; k < 3; ++k) write_slice(dir.file("mix/b" + std::to_string(k) + ".dcm"), b, k);
  EXPECT_PALP_ERROR(
      read_ct(dir.file("mix")), InputError,
      "mixed series: the directory holds 2 series (1.2.826.0.1.3680043.2.1125.1.1: 4 files, "
      "1.2.826.0.1.3680043.2.1125.1.2: 3 files), give a directory with one series");
}

TEST(DicomErrors, InconsistentSliceGap) {
  TempDir dir;
  const SeriesSpec spec;
  write_series(dir.path() / "gap", spec);
  write_slice(dir.file("gap/" + slice_name(5, 8)), spec, 5, 1.0);  // one slice 1 mm off
  EXPECT_PALP_ERROR(read_ct(dir.file("gap")), InputError,
                    "gap: inconsistent slice spacing: a gap of 3.5 mm between");
}

TEST(DicomErrors, DuplicatePosition) {
  TempDir dir;
  const SeriesSpec spec;
  write_series(dir.path() / "dup", spec);
  write_slice(dir.file("dup/extra.dcm"), spec, 2);
  EXPECT_PALP_ERROR(read_ct(dir.file("dup")), InputError, "duplicate slice position");
}

TEST(DicomErrors, InconsistentPixelSpacingAndSize) {
  TempDir dir;
  SeriesSpec spec;
  write_series(dir.path() / "ps", spec);
  SeriesSpec other = spec;
  other.column_spacing = 0.8;
  write_slice(dir.file("ps/" + slice_name(4, 8)), other, 4);
  EXPECT_PALP_ERROR(read_ct(dir.file("ps")), InputError,
                    "inconsistent PixelSpacing: 0.5\\0.75 in ");

  write_series(dir.path() / "size", spec);
  other = spec;
  other.rows = 10;
  write_slice(dir.file("size/" + slice_name(4, 8)), other, 4);
  EXPECT_PALP_ERROR(read_ct(dir.file("size")), InputError, "inconsistent image size: 16x12 in ");

  write_series(dir.path() / "iop", spec);
  other = spec;
  other.orientation = {0, 1, 0, 0, 0.6, -0.8};
  write_slice(dir.file("iop/" + slice_name(4, 8)), other, 4);
  EXPECT_PALP_ERROR(read_ct(dir.file("iop")), InputError, "inconsistent ImageOrientationPatient");
}

TEST(DicomErrors, TruncatedSliceIsNamed) {
  TempDir dir;
  write_series(dir.path() / "cut", SeriesSpec{});
  const std::string victim = dir.file("cut/" + slice_name(6, 8));
  // The intact slice, kept outside the series: every cut starts from the same bytes (slices differ
  // in length by a few bytes, since their generated UIDs do, so another slice's size is no bound).
  const std::string intact = dir.file("intact.dcm");
  std::filesystem::copy_file(victim, intact);
  // Every cut length from just past the magic to just before the end, so some cuts land exactly
  // on element boundaries (where only the missing image attributes give the truncation away).
  const std::size_t full = std::filesystem::file_size(intact);
  for (std::size_t keep = 140; keep < full; keep += 3) {
    std::filesystem::copy_file(intact, victim, std::filesystem::copy_options::overwrite_existing);
    ASSERT_LT(keep, std::filesystem::file_size(victim));  // a cut, never an extension
    std::filesystem::resize_file(victim, keep);
    SCOPED_TRACE("cut at " + std::to_string(keep) + " bytes");
    EXPECT_PALP_ERROR(read_ct(dir.file("cut")), InputError,
                      slice_name(6, 8) + ": corrupt or truncated DICOM file");
  }
}

TEST(DicomLayout, CompleteFilesPassAndCutsInsideThePixelDataAreFound) {
  TempDir dir;
  write_series(dir.path() / "raw", SeriesSpec{});
  transcode_series(dir.path() / "raw", dir.path() / "j2k", gdcm::TransferSyntax::JPEG2000Lossless);
  transcode_series(dir.path() / "raw", dir.path() / "rle", gdcm::TransferSyntax::RLELossless);
  for (const char* sub : {"raw", "j2k", "rle"}) {
    const auto bytes = testing::read_bytes(dir.file(std::string(sub) + "/" + slice_name(0, 8)));
    const std::vector<char> whole(bytes.begin(), bytes.end());
    EXPECT_EQ(DicomLayoutCheck(whole).run(), DicomLayoutCheck::Result::complete) << sub;
    for (std::size_t cut = 1; cut <= 100; ++cut) {
      const std::vector<char> part(whole.begin(), whole.end() - static_cast<std::ptrdiff_t>(cut));
      EXPECT_EQ(DicomLayoutCheck(part).run(), DicomLayoutCheck::Result::truncated)
          << sub << " cut " << cut;
    }
  }
}

// Sets Rows and Columns (explicit VR little endian US elements) in a file's bytes.
void claim_image_size(const std::string& path, std::uint16_t columns, std::uint16_t rows) {
  auto bytes = testing::read_bytes(path);
  const auto patch = [&](std::uint8_t element, std::uint16_t value) {
    const std::uint8_t tag[] = {0x28, 0x00, element, 0x00, 'U', 'S', 0x02, 0x00};
    const auto at = std::search(bytes.begin(), bytes.end(), std::begin(tag), std::end(tag));
    ASSERT_NE(at, bytes.end()) << path;
    testing::put(bytes, static_cast<std::size_t>(at - bytes.begin()) + 8, value);
  };
  patch(0x10, rows);
  patch(0x11, columns);
  testing::write_bytes(path, bytes);
}

// Eight RLE slices of a few hundred bytes each claiming 16384 x 16384 pixels: RLE decodes at most
// 64 bytes per stored byte, so each claim is refused before anything is allocated for it (the
// series volume alone would have been 4 GiB).
TEST(DicomErrors, TinySlicesClaimingHugeImagesAreRefusedBeforeAllocating) {
  TempDir dir;
  write_series(dir.path() / "raw", SeriesSpec{});
  transcode_series(dir.path() / "raw", dir.path() / "rle", gdcm::TransferSyntax::RLELossless);
  for (int k = 0; k < 8; ++k) claim_image_size(dir.file("rle/" + slice_name(k, 8)), 16384, 16384);
  testing::reset_peak_memory();
  const std::size_t before = testing::peak_memory_bytes();
  EXPECT_PALP_ERROR(read_ct(dir.file("rle")), InputError,
                    "Rows x Columns (16384x16384) claim 536870912 bytes of pixels, but its");
  EXPECT_LT(testing::peak_memory_bytes(), before + (64u << 20));
}

// Slices within the small allowance each (1024 x 1024 int16, 2 MiB) that add up past what the
// series' pixel data can back plus 256 MiB.
TEST(DicomErrors, ManySmallClaimsAddUpToARefusal) {
  TempDir dir;
  SeriesSpec spec;
  spec.slices = 139;  // prime to 5: slice_name gives each slice its own file
  write_series(dir.path() / "raw", spec);
  transcode_series(dir.path() / "raw", dir.path() / "rle", gdcm::TransferSyntax::RLELossless);
  for (int k = 0; k < spec.slices; ++k)
    claim_image_size(dir.file("rle/" + slice_name(k, spec.slices)), 1024, 1024);
  testing::reset_peak_memory();
  const std::size_t before = testing::peak_memory_bytes();
  EXPECT_PALP_ERROR(read_ct(dir.file("rle")), InputError,
                    "rle: the series claims 291504128 bytes of pixels, but its pixel data decodes");
  EXPECT_LT(testing::peak_memory_bytes(), before + (64u << 20));
}

// A 3 GB sparse file with the DICOM magic in a series directory is walked through a window and
// refused at its second element, not read into memory.
TEST(DicomErrors, ASparseGigabyteFileIsNotReadWhole) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "sparse");
  const std::string path = dir.file("sparse/zeros.dcm");
  std::vector<std::uint8_t> head(128, 0);
  for (char c : std::string("DICM")) head.push_back(static_cast<std::uint8_t>(c));
  testing::write_bytes(path, head);
  std::filesystem::resize_file(path, std::uint64_t{3} << 30);
  testing::reset_peak_memory();
  const std::size_t before = testing::peak_memory_bytes();
  EXPECT_PALP_ERROR(read_ct(dir.file("sparse")), InputError,
                    "zeros.dcm: corrupt DICOM file (element (0000,0000) at byte 140");
  EXPECT_LT(testing::peak_memory_bytes(), before + (64u << 20));
}

TEST(DicomErrors, GarbledHeaderDoesNotCrash) {
  TempDir dir;
  write_series(dir.path() / "bad", SeriesSpec{});
  const std::string victim = dir.file("bad/" + slice_name(1, 8));
  auto bytes = testing::read_bytes(victim);
  for (std::size_t at = 140; at < 600; at += 37) bytes[at] ^= 0xa5;
  testing::write_bytes(victim, bytes);
  EXPECT_PALP_ERROR(read_ct(dir.file("bad")), InputError, "bad");
}

TEST(DicomErrors, SingleFileIsNotASeries) {
  TempDir dir;
  write_slice(dir.file("one.dcm"), SeriesSpec{}, 0);
  EXPECT_PALP_ERROR(read_ct(dir.file("one.dcm")), InputError,
                    "give the directory that holds the series");
}

}  // namespace
}  // namespace palp
