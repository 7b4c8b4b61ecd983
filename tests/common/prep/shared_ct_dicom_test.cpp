// The shared CT (../shared/data/ct_abdomen_3mm.nii.gz) handed over as a PACS would: a DICOM CT
// series written here with GDCM the way scanners write one (one file per slice, LPS axial image
// plane, int16 stored values with RescaleIntercept -1024, file names that do not sort by
// position), transcoded to JPEG 2000. Lossless, read_ct and run_prep must give what they give on
// the NIfTI, voxel for voxel at the same patient positions; lossy (irreversible JPEG 2000 at
// archive ratios), the HU error and the bone mask against the expert labels are measured and
// bounded. Skips when the data is absent.
#include <gdcmAttribute.h>
#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gdcmJPEG2000Codec.h>
#include <gdcmSequenceOfFragments.h>
#include <gdcmTrace.h>
#include <gdcmUIDGenerator.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "io/ct_io.hpp"
#include "prep/prep.hpp"
#include "prep/segment/hu_levels.hpp"
#include "prep/segment/segmentation.hpp"
#include "support/bone_error_split.hpp"
#include "support/dicom_slice_writer.hpp"
#include "support/io_test_util.hpp"
#include "support/mask_metrics.hpp"
#include "support/shared_ct_labels.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

constexpr double kIntercept = -1024.0;  // stored value = HU + 1024, slope 1, as scanners store CT

const std::string kDataDir = PALP_SHARED_DATA_DIR;
const std::string kCtPath = kDataDir + "/ct_abdomen_3mm.nii.gz";

Vec3 world_of(const Grid& g, const Vec3& index) {
  Vec3 p = g.world.origin;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p[r] += g.world.direction[r * 3 + c] * g.spacing[c] * index[c];
  return p;
}

// The (fractional) index of world point `p` in `g` (its direction is orthonormal).
Vec3 index_of(const Grid& g, const Vec3& p) {
  Vec3 index{};
  for (int c = 0; c < 3; ++c) {
    double along = 0.0;
    for (int r = 0; r < 3; ++r) along += g.world.direction[r * 3 + c] * (p[r] - g.world.origin[r]);
    index[c] = along / g.spacing[c];
  }
  return index;
}

// For every voxel of `a`, the linear index of the voxel of `b` at the same world position. Fails
// the test when a voxel of `a` lies off b's voxel centres (by more than 1e-3 voxel) or outside b.
// `worst` gets the largest offset from a centre found, in voxels.
std::vector<std::size_t> same_position_voxels(const Grid& a, const Grid& b, double* worst) {
  std::vector<std::size_t> to_b(a.voxel_count());
  double largest = 0.0;
  std::size_t outside = 0;
  for (std::int64_t k = 0; k < a.dims[2]; ++k)
    for (std::int64_t j = 0; j < a.dims[1]; ++j)
      for (std::int64_t i = 0; i < a.dims[0]; ++i) {
        const Vec3 q = index_of(b, world_of(a, {double(i), double(j), double(k)}));
        Index3 n{};
        for (int c = 0; c < 3; ++c) {
          n[c] = std::llround(q[c]);
          largest = std::max(largest, std::fabs(q[c] - static_cast<double>(n[c])));
        }
        if (!b.contains(n[0], n[1], n[2])) {
          ++outside;
          continue;
        }
        to_b[a.linear(i, j, k)] = b.linear(n[0], n[1], n[2]);
      }
  EXPECT_EQ(outside, 0u) << "voxels of one grid outside the other";
  EXPECT_LE(largest, 1e-3) << "voxel centres of the two grids do not coincide";
  if (worst != nullptr) *worst = largest;
  return to_b;
}

// `v` (on b's grid) carried onto a's grid through `to_b`.
template <class T>
Volume<T> carried(const Volume<T>& v, const Grid& a, const std::vector<std::size_t>& to_b) {
  Volume<T> out(a, T{});
  for (std::size_t n = 0; n < out.size(); ++n) out.data[n] = v.data[to_b[n]];
  return out;
}

template <class T>
std::size_t count_different(const Volume<T>& a, const Volume<T>& b) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += a.data[i] != b.data[i];
  return n;
}

// ---- the series as a scanner writes it ----

// A scanner's axial series: the image rows run along +x of LPS (patient left), its columns along
// +y (posterior), slices ascend along +z (superior). `axis[d]` is the CT's index axis along LPS
// axis d and `flip[d]` whether it runs against it.
struct ScannerLayout {
  std::array<int, 3> axis{};
  std::array<bool, 3> flip{};
  Grid grid;  // the series' grid: what a reader sorting by position should give
};

ScannerLayout scanner_layout(const Grid& g) {
  ScannerLayout s;
  for (int d = 0; d < 3; ++d) {
    int best = 0;
    for (int a = 1; a < 3; ++a)
      if (std::fabs(g.world.direction[d * 3 + a]) > std::fabs(g.world.direction[d * 3 + best]))
        best = a;
    s.axis[d] = best;
    s.flip[d] = g.world.direction[d * 3 + best] < 0.0;
  }
  Vec3 first{};  // the CT's index of the series' voxel (0, 0, 0)
  for (int d = 0; d < 3; ++d) {
    const int a = s.axis[d];
    first[a] = s.flip[d] ? static_cast<double>(g.dims[a] - 1) : 0.0;
    s.grid.dims[d] = g.dims[a];
    s.grid.spacing[d] = g.spacing[a];
    for (int r = 0; r < 3; ++r)
      s.grid.world.direction[r * 3 + d] = (s.flip[d] ? -1.0 : 1.0) * g.world.direction[r * 3 + a];
  }
  s.grid.world.origin = world_of(g, first);
  return s;
}

// The CT's linear index of the series' voxel (c, r, s).
std::size_t ct_index(const Grid& g, const ScannerLayout& s, const Index3& series) {
  Index3 n{};
  for (int d = 0; d < 3; ++d) {
    const int a = s.axis[d];
    n[a] = s.flip[d] ? g.dims[a] - 1 - series[d] : series[d];
  }
  return g.linear(n[0], n[1], n[2]);
}

struct SeriesIds {
  std::string study, series;
};

void write_slice(const std::string& path, const CtVolume& ct, const ScannerLayout& s,
                 std::int64_t slice, const SeriesIds& ids) {
  const Grid& sg = s.grid;
  gdcm::ImageWriter writer;
  gdcm::Image& image = writer.GetImage();
  image.SetNumberOfDimensions(2);
  image.SetDimension(0, static_cast<unsigned>(sg.dims[0]));
  image.SetDimension(1, static_cast<unsigned>(sg.dims[1]));
  image.SetPixelFormat(gdcm::PixelFormat::INT16);
  image.SetPhotometricInterpretation(gdcm::PhotometricInterpretation::MONOCHROME2);
  image.SetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
  image.SetSpacing(0, sg.spacing[0]);
  image.SetSpacing(1, sg.spacing[1]);
  const Vec3 position = world_of(sg, {0.0, 0.0, static_cast<double>(slice)});
  for (unsigned a = 0; a < 3; ++a) image.SetOrigin(a, position[a]);
  const double cosines[6] = {sg.world.direction[0], sg.world.direction[3], sg.world.direction[6],
                             sg.world.direction[1], sg.world.direction[4], sg.world.direction[7]};
  image.SetDirectionCosines(cosines);
  image.SetIntercept(kIntercept);
  image.SetSlope(1.0);

  std::vector<std::int16_t> pixels(static_cast<std::size_t>(sg.dims[0] * sg.dims[1]));
  for (std::int64_t r = 0; r < sg.dims[1]; ++r)
    for (std::int64_t c = 0; c < sg.dims[0]; ++c)
      pixels[static_cast<std::size_t>(r * sg.dims[0] + c)] = static_cast<std::int16_t>(
          ct.data[ct_index(ct.grid, s, {c, r, slice})] - static_cast<int>(kIntercept));
  testing::set_int16_pixels(image, pixels);

  gdcm::DataSet& ds = writer.GetFile().GetDataSet();
  testing::set_ct_slice_identity(ds, ids.study, ids.series, static_cast<int>(slice) + 1);
  testing::set_dicom_string<0x0018, 0x5100>(ds, "HFS");  // patient position: head first, supine
  gdcm::Attribute<0x0018, 0x0050> thickness{sg.spacing[2]};
  ds.Replace(thickness.GetAsDataElement());
  writer.SetFileName(path.c_str());
  ASSERT_TRUE(writer.Write()) << path;
}

// Slice s goes to a file whose name does not sort by position (37 is prime to any count here
// that is not a multiple of 37).
std::string slice_file(std::int64_t s, std::int64_t slices) {
  char name[32];
  std::snprintf(name, sizeof name, "IM%05lld", static_cast<long long>((s * 37 + 11) % slices));
  return name;
}

void write_series(const fs::path& dir, const CtVolume& ct, const ScannerLayout& s) {
  fs::create_directories(dir);
  gdcm::UIDGenerator uid;
  const SeriesIds ids{uid.Generate(), uid.Generate()};
  for (std::int64_t k = 0; k < s.grid.dims[2]; ++k)
    write_slice((dir / slice_file(k, s.grid.dims[2])).string(), ct, s, k, ids);
}

struct Transcoded {
  std::uint64_t pixel_bytes = 0;  // compressed Pixel Data, all slices
  std::uint64_t raw_bytes = 0;    // what it decodes to
  double ratio() const { return static_cast<double>(raw_bytes) / static_cast<double>(pixel_bytes); }
};

// Copies every file of `from` into `to` as JPEG 2000: lossless (rate 0), or irreversible (9/7
// wavelet) at compression ratio `rate` (OpenJPEG's rate: raw bits over coded bits, an upper bound).
Transcoded transcode_j2k(const fs::path& from, const fs::path& to, double rate) {
  fs::create_directories(to);
  const bool lossless = rate == 0.0;
  const auto ts =
      lossless ? gdcm::TransferSyntax::JPEG2000Lossless : gdcm::TransferSyntax::JPEG2000;
  gdcm::JPEG2000Codec codec;
  if (!lossless) {
    codec.SetReversible(false);
    codec.SetRate(0, rate);
  }
  Transcoded out;
  for (const auto& entry : fs::directory_iterator(from)) {
    gdcm::ImageReader reader;
    reader.SetFileName(entry.path().c_str());
    EXPECT_TRUE(reader.Read()) << entry.path();
    gdcm::ImageChangeTransferSyntax change;
    change.SetTransferSyntax(ts);
    if (!lossless) change.SetUserCodec(&codec);
    change.SetInput(reader.GetImage());
    EXPECT_TRUE(change.Change()) << entry.path();
    gdcm::ImageWriter writer;
    writer.SetFileName((to / entry.path().filename()).c_str());
    writer.SetFile(reader.GetFile());
    writer.SetImage(change.GetOutput());
    EXPECT_TRUE(writer.Write()) << entry.path();
    const gdcm::DataElement& pixels = change.GetOutput().GetDataElement();
    const gdcm::SequenceOfFragments* fragments = pixels.GetSequenceOfFragments();
    EXPECT_NE(fragments, nullptr) << "not encapsulated: " << entry.path();
    if (fragments != nullptr) out.pixel_bytes += fragments->ComputeByteLength();
    out.raw_bytes += change.GetOutput().GetBufferLength();
  }
  // The copies really carry the transfer syntax asked for.
  gdcm::ImageReader check;
  check.SetFileName(fs::directory_iterator(to)->path().c_str());
  EXPECT_TRUE(check.Read());
  EXPECT_EQ(check.GetFile().GetHeader().GetDataSetTransferSyntax(), gdcm::TransferSyntax(ts));
  return out;
}

// The shared CT, its scanner layout, and the series written from it (raw, then JPEG 2000
// lossless) under one temporary directory.
struct SharedSeries {
  TempDir dir{"shared-ct-dicom"};
  CtVolume nifti;
  ScannerLayout layout;
  fs::path raw, j2k;
  Transcoded lossless;
};

bool make_series(SharedSeries& d) {
  if (!fs::exists(kCtPath)) return false;
  gdcm::Trace::WarningOff();  // new datasets have no PhotometricInterpretation until written
  d.nifti = read_ct(kCtPath);
  const auto [lo, hi] = std::minmax_element(d.nifti.data.begin(), d.nifti.data.end());
  EXPECT_GE(*lo - kIntercept, -32768.0);  // the stored values fit int16
  EXPECT_LE(*hi - kIntercept, 32767.0);
  d.layout = scanner_layout(d.nifti.grid);
  d.raw = d.dir.path() / "raw";
  d.j2k = d.dir.path() / "j2k";
  write_series(d.raw, d.nifti, d.layout);
  d.lossless = transcode_j2k(d.raw, d.j2k, 0.0);
  return true;
}

void expect_same_grid_geometry(const Grid& a, const Grid& b) {
  EXPECT_EQ(a.dims, b.dims);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(a.spacing[c], b.spacing[c], 1e-9) << "axis " << c;
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(a.world.origin[r], b.world.origin[r], 1e-6) << r;
  for (int n = 0; n < 9; ++n) EXPECT_NEAR(a.world.direction[n], b.world.direction[n], 1e-12) << n;
}

TEST(SharedCtDicom, LosslessJpeg2000SeriesReadsToTheNiftisHuAtTheSamePositions) {
  SharedSeries d;
  if (!make_series(d)) GTEST_SKIP() << "the shared CT is not in the data folder";
  const CtVolume series = read_ct(d.j2k.string());
  // The reader sorts the slices by position: the scanner's layout, which here stores the NIfTI's
  // first two axes reversed (it is RAS, the images run towards L and P).
  expect_same_grid_geometry(series.grid, d.layout.grid);
  double worst = 0.0;
  const auto to_series = same_position_voxels(d.nifti.grid, series.grid, &worst);
  EXPECT_EQ(count_different(carried(series, d.nifti.grid, to_series), d.nifti), 0u);
  // The uncompressed series reads to the same volume as its JPEG 2000 copy.
  EXPECT_EQ(read_ct(d.raw.string()).data, series.data);
  EXPECT_EQ(read_ct(d.raw.string()).grid, series.grid);
  double spacing_off = 0.0, origin_off = 0.0;  // DS values carry at most 16 characters
  for (int a = 0; a < 3; ++a) {
    spacing_off =
        std::max(spacing_off, std::fabs(series.grid.spacing[a] - d.layout.grid.spacing[a]));
    origin_off = std::max(origin_off,
                          std::fabs(series.grid.world.origin[a] - d.layout.grid.world.origin[a]));
  }
  std::printf(
      "JPEG 2000 lossless series: %lld files, compression %.2f:1, voxel centres within %.1e "
      "voxel of the NIfTI's (spacing off by %.1e mm, origin by %.1e mm)\n",
      static_cast<long long>(series.grid.dims[2]), d.lossless.ratio(), worst, spacing_off,
      origin_off);
}

// The maps are rounded to 1/1024 mm (prep/maps/subvoxel_distance.hpp,
// prep/maps/iso_projection.hpp): a distance that lands a hair either side of a rounding boundary in
// two storage orders differs by one such step.
constexpr float kMapStep = 1.0f / 1024.0f;

struct MapDifference {
  float largest = 0.0f;             // mm
  std::size_t differing = 0;        // nodes that differ at all
  std::size_t beyond_one_step = 0;  // by more than kMapStep
  std::size_t beyond_10um = 0;      // by more than 0.01 mm
};

MapDifference compare_maps(const std::string& nifti_map, const std::string& series_map) {
  const DistanceMap map = read_nifti_float(nifti_map);
  const DistanceMap other = read_nifti_float(series_map);
  const DistanceMap moved =
      carried(other, map.grid, same_position_voxels(map.grid, other.grid, nullptr));
  MapDifference d;
  for (std::size_t n = 0; n < map.size(); ++n) {
    const float e = std::fabs(map.data[n] - moved.data[n]);
    d.largest = std::max(d.largest, e);
    d.differing += e > 0.0f;
    d.beyond_one_step += e > 1.001f * kMapStep;
    d.beyond_10um += e > 0.01f;
  }
  std::printf(
      "%s: of %zu nodes %zu differ, %zu by more than 1/1024 mm, %zu by more than 0.01 mm; "
      "largest %.4f mm\n",
      fs::path(nifti_map).filename().c_str(), map.size(), d.differing, d.beyond_one_step,
      d.beyond_10um, d.largest);
  return d;
}

// Prep of the NIfTI and of the series: the same masks and the same levels; the maps the same up
// to their rounding step. d_surf's skin projection (prep/maps/iso_projection.hpp) starts from the
// sub-voxel map, so those steps move its start a little: a few nodes differ by a few steps.
// (Before the projection ran in a canonical storage order, 7 nodes differed by up to 0.37 mm.)
// PALP_DICOM_NO_SKIN_PROJECTION=1 preps without the projection.
TEST(SharedCtDicom, PrepOnTheSeriesGivesTheNiftisMasksAndMaps) {
  SharedSeries d;
  if (!make_series(d)) GTEST_SKIP() << "the shared CT is not in the data folder";
  PrepParams params;
  params.use_cache = false;
  const bool no_projection = std::getenv("PALP_DICOM_NO_SKIN_PROJECTION") != nullptr;
  if (no_projection) params.surface.skin_projection_mm = 0.0;
  const std::string nifti_out = d.dir.file("prep-nifti"), series_out = d.dir.file("prep-series");
  const PrepResult from_nifti = run_prep(kCtPath, nifti_out, params);
  const PrepResult from_series = run_prep(d.j2k.string(), series_out, params);
  EXPECT_EQ(from_nifti.orientation, "RAS");
  EXPECT_EQ(from_series.orientation, "LPS");
  EXPECT_FALSE(from_series.reoriented);
  EXPECT_EQ(from_series.hu_levels.soft_peak_hu, from_nifti.hu_levels.soft_peak_hu);
  EXPECT_EQ(from_series.hu_levels.offset_hu, from_nifti.hu_levels.offset_hu);
  EXPECT_EQ(from_series.stats.body_voxels, from_nifti.stats.body_voxels);
  EXPECT_EQ(from_series.stats.bone_voxels, from_nifti.stats.bone_voxels);

  // The CT copy, the body and the bone voxel for voxel at the same patient positions.
  const Mask body = read_nifti_mask(nifti_out + "/" + kBodyFile);
  const Mask series_body = read_nifti_mask(series_out + "/" + kBodyFile);
  const auto to_series = same_position_voxels(body.grid, series_body.grid, nullptr);
  EXPECT_EQ(count_different(carried(series_body, body.grid, to_series), body), 0u);
  const Mask bone = read_nifti_mask(nifti_out + "/" + kBoneFile);
  const Mask series_bone = read_nifti_mask(series_out + "/" + kBoneFile);
  EXPECT_EQ(count_different(carried(series_bone, bone.grid, to_series), bone), 0u);
  EXPECT_GT(testing::count(bone), 10000);
  const CtVolume ct = read_ct(nifti_out + "/" + kCtFile);
  EXPECT_EQ(count_different(carried(read_ct(series_out + "/" + kCtFile), ct.grid, to_series), ct),
            0u);

  const MapDifference bone_map =
      compare_maps(nifti_out + "/" + kBoneDistanceFile, series_out + "/" + kBoneDistanceFile);
  EXPECT_LE(bone_map.largest, 1.001f * kMapStep);
  const MapDifference skin_map =
      compare_maps(nifti_out + "/" + kSurfaceDistanceFile, series_out + "/" + kSurfaceDistanceFile);
  if (no_projection) {
    EXPECT_LE(skin_map.largest, 1.001f * kMapStep);
  } else {
    // Measured (deterministic): 17 of 1380064 nodes beyond one step, the largest 0.005 mm.
    EXPECT_EQ(skin_map.beyond_10um, 0u);
    EXPECT_LE(skin_map.largest, 0.01f);
  }
}

// ---- lossy JPEG 2000 ----

// The bone mask as prep makes it (body, the scan's HU levels, bone with the levels shifted).
Mask prep_bone(const CtVolume& ct, Mask* body_out = nullptr) {
  SegmentationParams params;
  const Mask body = segment_body(ct, params);
  const HuLevels levels = estimate_hu_levels(ct, body);
  params.bone_seed_hu += levels.offset_hu;
  params.bone_grow_hu += levels.offset_hu;
  Mask bone = segment_bone(ct, body, params);
  if (body_out != nullptr) *body_out = body;
  return bone;
}

struct LossyRow {
  double ratio = 0.0;                                  // achieved: raw pixel bytes over coded bytes
  double rms_hu = 0.0, max_hu = 0.0;                   // against the lossless series, all voxels
  double rms_body_hu = 0.0;                            // inside the lossless series' body mask
  double dice = 0.0, assd_mm = 0.0, rib_recall = 0.0;  // bone against the expert labels
  double dice_to_lossless = 0.0;                       // bone against the lossless series' bone
  std::size_t body_changed = 0;                        // body voxels that differ from lossless
};

struct Truth {
  Mask bone, superficial, body;  // on the NIfTI's grid; body: the lossless series' carried
};

LossyRow measure(const CtVolume& series, const CtVolume& reference, const Mask& reference_body,
                 const Mask& reference_bone, const Truth& truth,
                 const std::vector<std::size_t>& to_series) {
  LossyRow row;
  double sum = 0.0, sum_body = 0.0;
  std::size_t body_voxels = 0;
  for (std::size_t n = 0; n < series.size(); ++n) {
    const double e = static_cast<double>(series.data[n]) - reference.data[n];
    sum += e * e;
    row.max_hu = std::max(row.max_hu, std::fabs(e));
    if (reference_body.data[n]) sum_body += e * e, ++body_voxels;
  }
  row.rms_hu = std::sqrt(sum / static_cast<double>(series.size()));
  row.rms_body_hu = std::sqrt(sum_body / static_cast<double>(body_voxels));
  Mask body;
  const Mask bone_on_series = prep_bone(series, &body);
  row.body_changed = count_different(body, reference_body);
  row.dice_to_lossless = testing::dice(bone_on_series, reference_bone);
  const Mask bone = carried(bone_on_series, truth.bone.grid, to_series);
  row.dice = testing::dice(bone, truth.bone);
  row.assd_mm = testing::mean_surface_distance(bone, truth.bone);
  row.rib_recall = static_cast<double>(testing::count_both(truth.superficial, bone)) /
                   static_cast<double>(testing::count(truth.superficial));
  return row;
}

void print_row(const char* name, const LossyRow& r) {
  std::printf("| %s | %.1f:1 | %.1f | %.0f | %.1f | %zu | %.4f | %.3f | %.3f | %.3f |\n", name,
              r.ratio, r.rms_hu, r.max_hu, r.rms_body_hu, r.body_changed, r.dice_to_lossless,
              r.dice, r.assd_mm, r.rib_recall);
}

TEST(SharedCtDicom, LossyJpeg2000AtArchiveRatiosKeepsTheBoneMask) {
  SharedSeries d;
  if (!make_series(d)) GTEST_SKIP() << "the shared CT is not in the data folder";
  testing::LabelledCt labelled;  // the labels are measured against only
  if (!testing::load_labelled_shared_ct(labelled))
    GTEST_SKIP() << "the expert labels are not in the data folder";
  ASSERT_EQ(labelled.truth_bone.grid.dims, d.nifti.grid.dims);
  const CtVolume lossless = read_ct(d.j2k.string());
  const auto to_series = same_position_voxels(d.nifti.grid, lossless.grid, nullptr);
  Truth truth;
  truth.bone = std::move(labelled.truth_bone);
  Mask lossless_body;
  const Mask lossless_bone = prep_bone(lossless, &lossless_body);
  truth.body = carried(lossless_body, d.nifti.grid, to_series);
  truth.superficial = testing::superficial_bone(truth.bone, truth.body);

  std::printf(
      "| JPEG 2000 | ratio achieved | RMS HU error | max HU error | RMS HU error in the body | "
      "body voxels changed | bone Dice to lossless | bone Dice | ASSD mm | rib recall |\n");
  LossyRow reference = measure(lossless, lossless, lossless_body, lossless_bone, truth, to_series);
  reference.ratio = d.lossless.ratio();
  print_row("lossless", reference);
  // The lossless series' bone is the NIfTI's (bone_segmentation_test's figures, docs/prep.md).
  EXPECT_EQ(count_different(carried(lossless_bone, d.nifti.grid, to_series), prep_bone(d.nifti)),
            0u);

  // Ratios archives use for CT: 5:1 and 10:1 (published guidelines for lossy compression of body
  // CT allow about 5-15:1), and 20:1 beyond them. Bounds: measured (one run, deterministic for
  // Debian 12's OpenJPEG 2.5.0) with a margin; the figures are in docs/prep.md.
  struct Bound {
    double rate, rms_body_hu, dice_drop, assd_rise_mm, rib_recall_drop;
  };
  const Bound bounds[] = {
      {5.0, 12.0, 0.005, 0.1, 0.02}, {10.0, 25.0, 0.01, 0.25, 0.03}, {20.0, 50.0, 0.07, 0.75, 0.2}};
  for (const Bound& b : bounds) {
    const std::string name = "irreversible " + std::to_string(static_cast<int>(b.rate)) + ":1";
    SCOPED_TRACE(name);
    const fs::path dir = d.dir.path() / ("j2k-" + std::to_string(static_cast<int>(b.rate)));
    const Transcoded coded = transcode_j2k(d.raw, dir, b.rate);
    const CtVolume series = read_ct(dir.string());
    ASSERT_EQ(series.grid, lossless.grid);
    LossyRow row = measure(series, lossless, lossless_body, lossless_bone, truth, to_series);
    row.ratio = coded.ratio();
    print_row(name.c_str(), row);
    // Lossy for real, near the ratio asked for (OpenJPEG's rate bounds the size from above).
    EXPECT_GT(row.max_hu, 0.0);
    EXPECT_GE(row.ratio, 0.9 * b.rate);
    EXPECT_LE(row.ratio, 1.5 * b.rate);
    EXPECT_LE(row.rms_body_hu, b.rms_body_hu);
    EXPECT_GE(row.dice, reference.dice - b.dice_drop);
    EXPECT_LE(row.assd_mm, reference.assd_mm + b.assd_rise_mm);
    EXPECT_GE(row.rib_recall, reference.rib_recall - b.rib_recall_drop);
  }
}

}  // namespace
}  // namespace palp
