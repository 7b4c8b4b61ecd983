// DICOM series loading through GDCM: scan the directory, read headers, check the series is one
// regular grid, then decode slice by slice into HU. See dicom.hpp.
//
// All GDCM calls run in a forked child (child_process.hpp) that streams the grid and the slices
// back: the Debian build of GDCM aborts on malformed files, and that must not take palp down.
#include "io/dicom.hpp"

#include <gdcmAttribute.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmMediaStorage.h>
#include <gdcmReader.h>
#include <gdcmTrace.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <type_traits>

#include "base/errors.hpp"
#include "io/child_process.hpp"
#include "io/dicom_layout.hpp"

namespace palp {
namespace {

namespace fs = std::filesystem;
using Vector3 = std::array<double, 3>;

const gdcm::Tag kPixelData(0x7fe0, 0x0010);
const gdcm::Tag kSeriesInstanceUid(0x0020, 0x000e);
const gdcm::Tag kImagePosition(0x0020, 0x0032);
const gdcm::Tag kImageOrientation(0x0020, 0x0037);
const gdcm::Tag kPixelSpacing(0x0028, 0x0030);
const gdcm::Tag kNumberOfFrames(0x0028, 0x0008);
const gdcm::Tag kRescaleIntercept(0x0028, 0x1052);
const gdcm::Tag kRescaleSlope(0x0028, 0x1053);
const gdcm::Tag kSliceThickness(0x0018, 0x0050);
const gdcm::Tag kSpacingBetweenSlices(0x0018, 0x0088);

// What pass 1 learns about one image file.
struct SliceHeader {
  std::string file;
  std::string series_uid;
  unsigned rows = 0;
  unsigned columns = 0;
  std::optional<std::array<double, 2>> pixel_spacing;  // as stored: row spacing, column spacing
  std::optional<std::array<double, 6>> orientation;    // row direction, column direction
  std::optional<Vector3> position;
  double slope = 1.0;
  double intercept = 0.0;
  double thickness = 0.0;
  double along_normal = 0.0;  // position projected on the slice normal
  unsigned bits_allocated = 16;
  std::uint64_t image_bytes = 0;   // what Rows x Columns x BitsAllocated claim
  std::uint64_t backed_bytes = 0;  // the most its stored pixel data can decode to
};

std::string name_of(const std::string& file) {
  return fs::path(file).filename().string();
}

// ---- tag values ----

std::string string_value(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  if (!ds.FindDataElement(tag)) return {};
  const gdcm::ByteValue* bv = ds.GetDataElement(tag).GetByteValue();
  if (bv == nullptr) return {};
  std::string s(bv->GetPointer(), bv->GetLength());
  while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
  const auto first = s.find_first_not_of(' ');
  return first == std::string::npos ? std::string() : s.substr(first);
}

// A DS / IS value with `count` backslash-separated finite numbers; nullopt when absent or bad.
template <std::size_t N>
std::optional<std::array<double, N>> numbers(const gdcm::DataSet& ds, const gdcm::Tag& tag) {
  const std::string text = string_value(ds, tag);
  if (text.empty()) return std::nullopt;
  std::array<double, N> out{};
  std::size_t start = 0;
  for (std::size_t n = 0; n < N; ++n) {
    const std::size_t end = n + 1 < N ? text.find('\\', start) : text.size();
    if (end == std::string::npos) return std::nullopt;
    std::string part = text.substr(start, end - start);
    part.erase(0, part.find_first_not_of(' '));
    part.erase(part.find_last_not_of(' ') + 1);
    if (!part.empty() && part.front() == '+') part.erase(0, 1);
    const auto [ptr, ec] = std::from_chars(part.data(), part.data() + part.size(), out[n]);
    if (ec != std::errc() || ptr != part.data() + part.size() || !std::isfinite(out[n]))
      return std::nullopt;
    start = end + 1;
  }
  return out;
}

double number_or(const gdcm::DataSet& ds, const gdcm::Tag& tag, double fallback) {
  const auto value = numbers<1>(ds, tag);
  return value ? (*value)[0] : fallback;
}

template <std::uint16_t Group, std::uint16_t Element>
unsigned us_value(const gdcm::DataSet& ds) {
  gdcm::Attribute<Group, Element> attribute{};
  if (!ds.FindDataElement(attribute.GetTag()) || ds.GetDataElement(attribute.GetTag()).IsEmpty())
    return 0;
  attribute.SetFromDataSet(ds);
  return attribute.GetValue();
}

// ---- pass 1: headers ----

std::vector<std::string> list_files(const std::string& directory) {
  std::vector<std::string> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(directory, ec)) {
    if (entry.is_regular_file(ec)) {
      files.push_back(entry.path().string());
    } else if (entry.is_directory(ec)) {  // one level of subdirectories
      for (const auto& inner : fs::directory_iterator(entry.path(), ec))
        if (inner.is_regular_file(ec)) files.push_back(inner.path().string());
    }
  }
  if (ec) throw InputError(directory + ": cannot list the directory (" + ec.message() + ")");
  std::sort(files.begin(), files.end());
  return files;
}

// DICOM files (Part 10) start with a 128-byte preamble and "DICM". Files without it are not
// handed to GDCM at all.
bool has_dicom_magic(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  char head[132] = {};
  in.read(head, sizeof head);
  return in.gcount() == sizeof head && std::memcmp(head + 128, "DICM", 4) == 0;
}

// How many decoded bytes one byte of stored pixel data may stand for: native 1; RLE 64 (PackBits
// repeats a byte at most 128 times for 2 bytes); the JPEG family and JPEG 2000 have no useful
// theoretical bound (JPEG-LS run mode, empty JPEG 2000 code blocks), palp allows deflate's 1032.
std::uint64_t max_decode_ratio(const std::string& syntax) {
  if (syntax == "1.2.840.10008.1.2" || syntax == "1.2.840.10008.1.2.1" ||
      syntax == "1.2.840.10008.1.2.2")
    return 1;
  if (syntax == "1.2.840.10008.1.2.5") return 64;
  return 1032;
}

// A slice may claim this much whatever its bytes (a blank 1024x1024 slice compresses past any
// ratio); a series may claim this much more than its bytes back in all.
constexpr std::uint64_t kFreeSliceBytes = std::uint64_t{2} << 20;
constexpr std::uint64_t kFreeSeriesBytes = std::uint64_t{256} << 20;
// Pixel data may be larger than the image it decodes to (a codec's overhead), but not by more.
constexpr std::uint64_t kPixelDataSlack = std::uint64_t{64} << 10;

// What the structural walk learned about a file's pixel data.
struct PixelDataLayout {
  std::string syntax;
  std::uint64_t bytes = 0;  // stored bytes of the Pixel Data (the file's size when not walked)
};

PixelDataLayout check_layout(const std::string& file) {
  DicomLayoutCheck layout(file);
  const DicomLayoutCheck::Result result = layout.run();
  if (result == DicomLayoutCheck::Result::truncated)
    throw InputError(file + ": corrupt or truncated DICOM file (an element runs past its end)");
  if (result == DicomLayoutCheck::Result::refused)
    throw InputError(file + ": corrupt DICOM file (" + layout.reason() + ")");
  if (layout.transfer_syntax() == "1.2.840.10008.1.2.1.99")
    throw InputError(file +
                     ": the deflated transfer syntax is not supported (its size cannot be "
                     "bounded before inflating it; store the series uncompressed or with an "
                     "image codec)");
  const auto storage = gdcm::MediaStorage::GetMSType(layout.media_storage_sop_class().c_str());
  if (result == DicomLayoutCheck::Result::complete && !layout.has_pixel_data() &&
      gdcm::MediaStorage::IsImage(storage))
    throw InputError(file + ": corrupt or truncated DICOM file (an image without pixel data)");
  const bool walked = result == DicomLayoutCheck::Result::complete;
  return {layout.transfer_syntax(), walked ? layout.pixel_data_bytes() : layout.file_bytes()};
}

// Refuses a slice whose Rows x Columns claim more pixel bytes than its stored pixel data can
// decode to, or whose pixel data is far larger than its image (GDCM reads it whole).
void check_pixel_claim(SliceHeader& h, const PixelDataLayout& layout) {
  h.image_bytes = std::uint64_t{h.rows} * h.columns * (h.bits_allocated / 8);
  h.backed_bytes = layout.bytes * max_decode_ratio(layout.syntax);
  const std::string ts = layout.syntax.empty() ? "?" : layout.syntax;
  const std::string size = std::to_string(h.columns) + "x" + std::to_string(h.rows);
  if (layout.bytes > 2 * h.image_bytes + kPixelDataSlack)
    throw InputError(h.file + ": " + std::to_string(layout.bytes) + " bytes of pixel data for a " +
                     size + " image of " + std::to_string(h.image_bytes) + " bytes");
  if (h.image_bytes > std::max(kFreeSliceBytes, h.backed_bytes))
    throw InputError(h.file + ": Rows x Columns (" + size + ") claim " +
                     std::to_string(h.image_bytes) + " bytes of pixels, but its " +
                     std::to_string(layout.bytes) + " bytes of pixel data (transfer syntax " + ts +
                     ") decode to at most " + std::to_string(h.backed_bytes));
}

// nullopt for DICOM files that hold no image (DICOMDIR, reports, ...).
std::optional<SliceHeader> read_slice_header(const std::string& file) {
  const PixelDataLayout layout = check_layout(file);
  gdcm::Reader reader;
  reader.SetFileName(file.c_str());
  if (!reader.ReadUpToTag(kPixelData))
    throw InputError(file + ": corrupt or truncated DICOM file (its header cannot be parsed)");
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  SliceHeader h;
  h.file = file;
  h.rows = us_value<0x0028, 0x0010>(ds);
  h.columns = us_value<0x0028, 0x0011>(ds);
  if (h.rows == 0 || h.columns == 0) return std::nullopt;
  if (number_or(ds, kNumberOfFrames, 1.0) > 1.0)
    throw InputError(
        file + ": multi-frame DICOM images are not supported (give a series of single slices)");
  const unsigned samples = us_value<0x0028, 0x0002>(ds);
  if (samples > 1)
    throw InputError(file + ": " + std::to_string(samples) +
                     " samples per pixel (only greyscale CT is supported)");
  h.bits_allocated = us_value<0x0028, 0x0100>(ds);
  if (h.bits_allocated != 8 && h.bits_allocated != 16)
    throw InputError(file + ": BitsAllocated " + std::to_string(h.bits_allocated) +
                     " is not supported (8 or 16)");
  check_pixel_claim(h, layout);
  h.series_uid = string_value(ds, kSeriesInstanceUid);
  h.pixel_spacing = numbers<2>(ds, kPixelSpacing);
  h.orientation = numbers<6>(ds, kImageOrientation);
  h.position = numbers<3>(ds, kImagePosition);
  h.slope = number_or(ds, kRescaleSlope, 1.0);
  h.intercept = number_or(ds, kRescaleIntercept, 0.0);
  h.thickness = number_or(ds, kSpacingBetweenSlices, number_or(ds, kSliceThickness, 0.0));
  return h;
}

// The whole series may claim at most what its pixel data backs plus kFreeSeriesBytes: many tiny
// files, each within kFreeSliceBytes, must not add up to gigabytes.
void check_series_claim(const std::vector<SliceHeader>& slices, const std::string& directory) {
  std::uint64_t claimed = 0;
  std::uint64_t backed = 0;
  for (const auto& s : slices) {
    claimed += s.image_bytes;
    backed += std::min(s.backed_bytes, s.image_bytes);
  }
  if (claimed > backed + kFreeSeriesBytes)
    throw InputError(directory + ": the series claims " + std::to_string(claimed) +
                     " bytes of pixels, but its pixel data decodes to at most " +
                     std::to_string(backed) + " (" + std::to_string(kFreeSeriesBytes) +
                     " more are allowed)");
}

void require_single_series(const std::vector<SliceHeader>& slices, const std::string& directory) {
  std::map<std::string, int> counts;
  for (const auto& s : slices) ++counts[s.series_uid];
  if (counts.size() == 1) return;
  std::ostringstream msg;
  msg << directory << ": mixed series: the directory holds " << counts.size() << " series (";
  int shown = 0;
  for (const auto& [uid, count] : counts) {
    if (shown++ == 4) {
      msg << ", ...";
      break;
    }
    msg << (shown > 1 ? ", " : "") << (uid.empty() ? "<no SeriesInstanceUID>" : uid) << ": "
        << count << " files";
  }
  msg << "), give a directory with one series";
  throw InputError(msg.str());
}

// ---- pass 1b: one regular grid ----

template <std::size_t N>
std::string join(const std::array<double, N>& values) {
  std::ostringstream s;
  for (std::size_t i = 0; i < N; ++i) s << (i ? "\\" : "") << values[i];
  return s.str();
}

template <std::size_t N>
bool close(const std::array<double, N>& a, const std::array<double, N>& b, double tolerance) {
  for (std::size_t i = 0; i < N; ++i)
    if (std::fabs(a[i] - b[i]) > tolerance * std::max(1.0, std::fabs(a[i]))) return false;
  return true;
}

void check_consistent(const std::vector<SliceHeader>& slices, const std::string& directory) {
  const SliceHeader& first = slices.front();
  for (const auto& s : slices) {
    if (!s.pixel_spacing) throw InputError(s.file + ": no usable PixelSpacing");
    if (!s.orientation) throw InputError(s.file + ": no usable ImageOrientationPatient");
    if (!s.position) throw InputError(s.file + ": no usable ImagePositionPatient");
  }
  for (const auto& s : slices) {
    const std::string pair = " in " + name_of(first.file) + " but ";
    if (s.rows != first.rows || s.columns != first.columns)
      throw InputError(directory + ": inconsistent image size: " + std::to_string(first.columns) +
                       "x" + std::to_string(first.rows) + pair + std::to_string(s.columns) + "x" +
                       std::to_string(s.rows) + " in " + name_of(s.file));
    if (!close(*s.pixel_spacing, *first.pixel_spacing, 1e-4))
      throw InputError(directory + ": inconsistent PixelSpacing: " + join(*first.pixel_spacing) +
                       pair + join(*s.pixel_spacing) + " in " + name_of(s.file));
    if (!close(*s.orientation, *first.orientation, 1e-4))
      throw InputError(directory +
                       ": inconsistent ImageOrientationPatient: " + join(*first.orientation) +
                       pair + join(*s.orientation) + " in " + name_of(s.file));
  }
}

Vector3 normalized(const Vector3& v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return {v[0] / n, v[1] / n, v[2] / n};
}

Vector3 cross(const Vector3& a, const Vector3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

double dot(const Vector3& a, const Vector3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

struct SliceAxes {
  Vector3 row, column, normal;
};

SliceAxes slice_axes(const SliceHeader& s) {
  const auto& o = *s.orientation;
  const Vector3 row{o[0], o[1], o[2]};
  const Vector3 column{o[3], o[4], o[5]};
  const Vector3 normal = cross(row, column);
  if (!(dot(normal, normal) > 1e-6))
    throw InputError(s.file + ": ImageOrientationPatient " + join(o) + " has parallel axes");
  return {normalized(row), normalized(column), normalized(normal)};
}

// Sorts by position along the normal and returns the slice gap (mm).
double sort_and_check_gaps(std::vector<SliceHeader>& slices, const Vector3& normal,
                           const std::string& directory) {
  for (auto& s : slices) s.along_normal = dot(*s.position, normal);
  std::sort(slices.begin(), slices.end(), [](const SliceHeader& a, const SliceHeader& b) {
    return a.along_normal < b.along_normal;
  });
  if (slices.size() == 1) return slices[0].thickness > 0.0 ? slices[0].thickness : 1.0;
  for (std::size_t k = 1; k < slices.size(); ++k) {
    if (slices[k].along_normal - slices[k - 1].along_normal < 1e-3)
      throw InputError(directory + ": duplicate slice position " +
                       std::to_string(slices[k].along_normal) + " mm (" +
                       name_of(slices[k - 1].file) + " and " + name_of(slices[k].file) + ")");
  }
  const double mean = (slices.back().along_normal - slices.front().along_normal) /
                      static_cast<double>(slices.size() - 1);
  const double tolerance = std::max(0.01, 0.01 * mean);
  for (std::size_t k = 1; k < slices.size(); ++k) {
    const double gap = slices[k].along_normal - slices[k - 1].along_normal;
    if (std::fabs(gap - mean) > tolerance) {
      std::ostringstream msg;
      msg << directory << ": inconsistent slice spacing: a gap of " << gap << " mm between "
          << name_of(slices[k - 1].file) << " and " << name_of(slices[k].file) << ", " << mean
          << " mm on average (missing or extra slices?)";
      throw InputError(msg.str());
    }
  }
  return mean;
}

Grid series_grid(const std::vector<SliceHeader>& slices, const SliceAxes& axes, double gap) {
  const SliceHeader& first = slices.front();
  Grid grid;
  grid.dims = {first.columns, first.rows, static_cast<std::int64_t>(slices.size())};
  grid.spacing = {(*first.pixel_spacing)[1], (*first.pixel_spacing)[0], gap};
  grid.world.origin = *first.position;
  const Vector3* columns[3] = {&axes.row, &axes.column, &axes.normal};
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) grid.world.direction[r * 3 + c] = (*columns[c])[r];
  return grid;
}

// ---- pass 2: pixels ----

std::int16_t hu_from(double value) {
  return static_cast<std::int16_t>(std::clamp(std::round(value), -32768.0, 32767.0));
}

// Stored value of pixel `i`, honouring BitsStored < BitsAllocated and the sign.
template <class Raw>
std::int64_t stored_value(const char* buffer, std::size_t i, unsigned bits_stored, bool is_signed) {
  Raw raw;
  std::memcpy(&raw, buffer + i * sizeof(Raw), sizeof(Raw));
  std::uint64_t bits = static_cast<std::make_unsigned_t<Raw>>(raw);
  if (bits_stored < 8 * sizeof(Raw)) bits &= (std::uint64_t{1} << bits_stored) - 1;
  if (is_signed && (bits >> (bits_stored - 1)) & 1u)
    return static_cast<std::int64_t>(bits) - (std::int64_t{1} << bits_stored);
  return static_cast<std::int64_t>(bits);
}

template <class Raw>
void pixels_to_hu(const char* buffer, std::size_t count, const gdcm::PixelFormat& format,
                  const SliceHeader& s, std::int16_t* out) {
  const unsigned bits_stored = std::clamp<unsigned>(format.GetBitsStored(), 1, 8 * sizeof(Raw));
  const bool is_signed = format.GetPixelRepresentation() == 1;
  for (std::size_t i = 0; i < count; ++i)
    out[i] = hu_from(static_cast<double>(stored_value<Raw>(buffer, i, bits_stored, is_signed)) *
                         s.slope +
                     s.intercept);
}

void decode_slice(const SliceHeader& s, std::int16_t* out) {
  gdcm::ImageReader reader;
  reader.SetFileName(s.file.c_str());
  if (!reader.Read())
    throw InputError(s.file + ": corrupt or truncated DICOM file (its image cannot be read)");
  const gdcm::Image& image = reader.GetImage();
  const gdcm::PixelFormat& format = image.GetPixelFormat();
  if (image.GetDimension(0) != s.columns || image.GetDimension(1) != s.rows)
    throw InputError(s.file + ": image size differs from its Rows/Columns");
  if (format.GetSamplesPerPixel() != 1)
    throw InputError(s.file + ": " + std::to_string(format.GetSamplesPerPixel()) +
                     " samples per pixel (only greyscale CT is supported)");
  const unsigned bits = format.GetBitsAllocated();
  if (bits != 8 && bits != 16)
    throw InputError(s.file + ": BitsAllocated " + std::to_string(bits) +
                     " is not supported (8 or 16)");
  const std::size_t count = std::size_t{s.rows} * s.columns;
  std::vector<char> buffer(image.GetBufferLength());
  if (buffer.size() < count * (bits / 8) || !image.GetBuffer(buffer.data()))
    throw InputError(s.file + ": cannot decode the pixel data (transfer syntax " +
                     std::string(image.GetTransferSyntax().GetString()
                                     ? image.GetTransferSyntax().GetString()
                                     : "?") +
                     ")");
  if (bits == 8) {
    pixels_to_hu<std::uint8_t>(buffer.data(), count, format, s, out);
  } else {
    pixels_to_hu<std::uint16_t>(buffer.data(), count, format, s, out);
  }
}

// GDCM reports every non-DICOM file it is shown on stderr; palp reports errors itself.
void quiet_gdcm() {
  gdcm::Trace::DebugOff();
  gdcm::Trace::WarningOff();
  gdcm::Trace::ErrorOff();
}

// ---- the child: all GDCM work ----

// Record types the child sends.
constexpr char kNowReading = 'F';  // payload: the file GDCM is about to read
constexpr char kGrid = 'G';        // payload: the Grid
constexpr char kSlice = 'S';       // payload: one slice of int16 HU
constexpr char kInputError = 'I';  // payload: the message
constexpr char kResourceError = 'R';
constexpr char kDone = 'D';

std::vector<SliceHeader> read_headers(const std::vector<std::string>& files, std::size_t all_files,
                                      const std::string& directory, ChildWriter& out) {
  std::vector<SliceHeader> slices;
  for (const auto& file : files) {
    out.send(kNowReading, file);
    if (auto h = read_slice_header(file)) slices.push_back(std::move(*h));
  }
  if (slices.empty())
    throw InputError(directory + ": no DICOM images among " + std::to_string(all_files) + " files");
  return slices;
}

void load_series(const std::vector<std::string>& files, std::size_t all_files,
                 const std::string& directory, ChildWriter& out) {
  quiet_gdcm();
  std::vector<SliceHeader> slices = read_headers(files, all_files, directory, out);
  check_series_claim(slices, directory);
  require_single_series(slices, directory);
  check_consistent(slices, directory);
  const SliceAxes axes = slice_axes(slices.front());
  const double gap = sort_and_check_gaps(slices, axes.normal, directory);
  const Grid grid = series_grid(slices, axes, gap);
  validate_grid(grid, directory);
  out.send(kGrid, &grid, sizeof grid);
  std::vector<std::int16_t> slice(static_cast<std::size_t>(grid.dims[0] * grid.dims[1]));
  for (const auto& s : slices) {
    out.send(kNowReading, s.file);
    decode_slice(s, slice.data());
    out.send(kSlice, slice.data(), slice.size() * sizeof(std::int16_t));
  }
  out.send(kDone, std::string());
}

void load_series_reporting_errors(const std::vector<std::string>& files, std::size_t all_files,
                                  const std::string& directory, ChildWriter& out) {
  try {
    load_series(files, all_files, directory, out);
  } catch (const ResourceError& e) {
    out.send(kResourceError, e.what());
  } catch (const std::bad_alloc&) {
    out.send(kResourceError, directory + ": out of memory while reading the series");
  } catch (const std::exception& e) {
    out.send(kInputError, e.what());
  }
}

// ---- the parent: assemble the volume ----

CtVolume receive_series(IsolatedChild& child, const std::string& directory) {
  std::optional<CtVolume> volume;
  std::size_t filled = 0;  // bytes of volume data received
  std::string reading;
  ChildRecord record;
  while (child.next(record)) {
    switch (record.type) {
      case kNowReading:
        reading = record.text();
        break;
      case kGrid: {
        Grid grid;
        if (record.payload.size() != sizeof grid) break;
        std::memcpy(&grid, record.payload.data(), sizeof grid);
        volume.emplace(grid, 0, directory);  // validates and checks memory before allocating
        break;
      }
      case kSlice: {
        const std::size_t bytes = volume ? volume->size() * sizeof(std::int16_t) : 0;
        if (filled + record.payload.size() > bytes) break;
        std::memcpy(reinterpret_cast<char*>(volume->data.data()) + filled, record.payload.data(),
                    record.payload.size());
        filled += record.payload.size();
        break;
      }
      case kInputError:
        throw InputError(record.text());
      case kResourceError:
        throw ResourceError(record.text());
      case kDone:
        if (volume && filled == volume->size() * sizeof(std::int16_t) && child.wait())
          return std::move(*volume);
        throw InputError(directory + ": the DICOM reader stopped before the series was complete");
      default:
        break;
    }
  }
  child.wait();
  throw InputError((reading.empty() ? directory : reading) +
                   ": corrupt or truncated DICOM file (the DICOM library aborted reading it)");
}

}  // namespace

CtVolume read_dicom_series(const std::string& directory) {
  const std::vector<std::string> all_files = list_files(directory);
  if (all_files.empty()) throw InputError(directory + ": directory is empty");
  std::vector<std::string> dicom_files;
  for (const auto& file : all_files)
    if (has_dicom_magic(file)) dicom_files.push_back(file);
  if (dicom_files.empty())
    throw InputError(directory + ": no DICOM images among " + std::to_string(all_files.size()) +
                     " files");
  IsolatedChild child([&](ChildWriter& out) {
    load_series_reporting_errors(dicom_files, all_files.size(), directory, out);
  });
  return receive_series(child, directory);
}

}  // namespace palp
