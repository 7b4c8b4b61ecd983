// CT input dispatch, the shared voxel loader (a parsed header -> a volume of HU, float or mask
// values), and the NIfTI writers of ct_io.hpp.
#include "io/ct_io.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "io/dicom.hpp"
#include "io/gzip_index.hpp"
#include "io/metaimage.hpp"
#include "io/nifti.hpp"
#include "io/nrrd.hpp"
#include "io/phantom.hpp"
#include "io/stored_image.hpp"

namespace palp {
namespace {

// ---- value conversion ----

// HU stored for a NaN input: air.
constexpr std::int16_t kNanHu = -1024;

template <class Out>
Out from_double(double v) {
  if constexpr (std::is_same_v<Out, std::int16_t>) {
    if (std::isnan(v)) return kNanHu;
    return static_cast<std::int16_t>(std::clamp(std::round(v), -32768.0, 32767.0));
  } else if constexpr (std::is_same_v<Out, float>) {
    return static_cast<float>(v);
  } else {
    static_assert(std::is_same_v<Out, std::uint8_t>);
    return v != 0.0 ? 1 : 0;
  }
}

// Stored value -> Out without scaling (exact for integers).
template <class Out, class In>
Out from_stored(In v) {
  if constexpr (std::is_same_v<Out, std::int16_t> && std::is_integral_v<In>) {
    if constexpr (std::is_signed_v<In>) {
      return static_cast<std::int16_t>(std::clamp<std::int64_t>(v, -32768, 32767));
    } else {
      return static_cast<std::int16_t>(std::min<std::uint64_t>(v, 32767));
    }
  } else if constexpr (std::is_same_v<Out, std::uint8_t>) {
    return v != 0 ? 1 : 0;
  } else {
    return from_double<Out>(static_cast<double>(v));
  }
}

template <class In, class Out, bool kSwap, bool kScale>
void convert_values(const std::uint8_t* src, std::size_t n, double slope, double intercept,
                    Out* dst) {
  for (std::size_t i = 0; i < n; ++i) {
    In v;
    std::memcpy(&v, src + i * sizeof(In), sizeof(In));
    if constexpr (kSwap) v = byte_swapped(v);
    if constexpr (kScale) {
      dst[i] = from_double<Out>(static_cast<double>(v) * slope + intercept);
    } else {
      dst[i] = from_stored<Out>(v);
    }
  }
}

template <class In, class Out>
void convert_typed(const std::uint8_t* src, std::size_t n, const StoredVoxels& v, Out* dst) {
  const bool swap = v.big_endian != kHostIsBigEndian;
  const bool scale = !(v.slope == 1.0 && v.intercept == 0.0);
  if (swap) {
    scale ? convert_values<In, Out, true, true>(src, n, v.slope, v.intercept, dst)
          : convert_values<In, Out, true, false>(src, n, v.slope, v.intercept, dst);
  } else {
    scale ? convert_values<In, Out, false, true>(src, n, v.slope, v.intercept, dst)
          : convert_values<In, Out, false, false>(src, n, v.slope, v.intercept, dst);
  }
}

// Converts n stored values of v.type at `src` into `dst`.
template <class Out>
void convert(const std::uint8_t* src, std::size_t n, const StoredVoxels& v, Out* dst) {
  switch (v.type) {
    case ScalarType::u8:
      return convert_typed<std::uint8_t>(src, n, v, dst);
    case ScalarType::i8:
      return convert_typed<std::int8_t>(src, n, v, dst);
    case ScalarType::u16:
      return convert_typed<std::uint16_t>(src, n, v, dst);
    case ScalarType::i16:
      return convert_typed<std::int16_t>(src, n, v, dst);
    case ScalarType::u32:
      return convert_typed<std::uint32_t>(src, n, v, dst);
    case ScalarType::i32:
      return convert_typed<std::int32_t>(src, n, v, dst);
    case ScalarType::u64:
      return convert_typed<std::uint64_t>(src, n, v, dst);
    case ScalarType::i64:
      return convert_typed<std::int64_t>(src, n, v, dst);
    case ScalarType::f32:
      return convert_typed<float>(src, n, v, dst);
    case ScalarType::f64:
      return convert_typed<double>(src, n, v, dst);
  }
}

// ---- reading voxels ----

// Largest ratio of decompressed to compressed size deflate can reach (about 1032:1): a claim
// beyond it is refused before anything is read.
constexpr std::uint64_t kMaxDeflateRatio = 1032;
// A compressed stream's volume starts with room for this ratio (real CT compresses 2-5:1, so a
// real volume gets all its room at once) and grows, doubling, as decoded bytes arrive.
constexpr std::uint64_t kFirstRoomRatio = 16;
constexpr std::size_t kChunkBytes = std::size_t{1} << 20;

[[noreturn]] void throw_short_data(const std::string& path, std::uint64_t need,
                                   std::uint64_t have) {
  throw InputError(path + ": header says " + std::to_string(need) +
                   " bytes of voxel data, file has " + std::to_string(have));
}

// Where the stream holding the voxels starts, checked against the file size before anything is
// allocated: raw voxels must all be in the file, compressed ones within deflate's ratio of it.
// `compressed` is set to the compressed bytes (0 for raw voxels).
std::uint64_t check_data_size(const StoredVoxels& v, std::uint64_t need,
                              std::uint64_t& compressed) {
  const std::uint64_t size = file_size(v.path);
  compressed = 0;
  if (v.compression == Compression::none) {
    if (v.at_end_of_file) {
      if (size < need) throw_short_data(v.path, need, size);
      return size - need;
    }
    const std::uint64_t begin = v.file_offset + v.skip;
    const std::uint64_t have = size > begin ? size - begin : 0;
    if (have < need) throw_short_data(v.path, need, have);
    return v.file_offset;
  }
  compressed = size > v.file_offset ? size - v.file_offset : 0;
  const std::uint64_t most = compressed * kMaxDeflateRatio;
  if (need + v.skip > most)
    throw InputError(v.path + ": header says " + std::to_string(need) +
                     " bytes of voxel data, file has " + std::to_string(compressed) +
                     " compressed bytes (at most " + std::to_string(most) + " decompressed)");
  return v.file_offset;
}

// After the last voxel of a compressed stream, lets zlib reach the stream's end so that the
// checksum is verified (a corrupt trailer throws); anything after the voxels is ignored.
void finish_stream(DecodedReader& reader) {
  std::uint8_t extra[64];
  reader.read(extra, sizeof extra);
}

// Reads the voxels. The volume's memory follows the bytes that have arrived: raw voxels were
// checked against the file size, so their volume is allocated at once; a compressed stream may
// decode to less than its header claims (deflate reaches 1032:1, so a 2 MB stream can claim 2 GB),
// so its volume grows as decoded bytes arrive and a lying header costs what the stream holds.
template <class Out>
Volume<Out> load_volume(const StoredImage& image) {
  const StoredVoxels& v = image.voxels;
  validate_grid(image.grid, v.path);
  const std::size_t element = scalar_size(v.type);
  const std::uint64_t count = image.grid.voxel_count();
  const std::uint64_t need = count * element;
  std::uint64_t compressed = 0;
  const std::uint64_t start = check_data_size(v, need, compressed);
  check_allocation(image.grid, sizeof(Out), v.path);

  Volume<Out> volume;
  volume.grid = image.grid;
  // palp's own gzip files say where each member lies: decoded on all cores (gzip_index.hpp).
  // The volume is then allocated whole before the members are checked, so only for a claim
  // within the room the streaming reader would reserve at once (16:1; palp's CT and maps are
  // 2-5:1): a lying header still costs no more than that.
  if (v.compression == Compression::gzip && v.file_offset == 0 && !v.at_end_of_file &&
      need + v.skip <= compressed * kFirstRoomRatio) {
    if (read_indexed_gzip(
            v.path, v.skip, need, element, default_thread_count(),
            [&] { volume.data.resize(static_cast<std::size_t>(count)); },
            [&](std::uint64_t at, const std::uint8_t* bytes, std::size_t size) {
              convert(bytes, size / element, v, volume.data.data() + at / element);
            }))
      return volume;
    volume.data = {};  // not indexed (or damaged): the streaming reader below says what it finds
  }
  std::uint64_t room = count;
  if (v.compression != Compression::none)
    room = std::clamp<std::uint64_t>(compressed * kFirstRoomRatio / element, 1, count);
  volume.data.reserve(static_cast<std::size_t>(room));

  DecodedReader reader(v.path, start, v.compression);
  if (!v.at_end_of_file && v.skip > 0 && reader.skip(v.skip) < v.skip)
    throw_short_data(v.path, need, 0);

  std::vector<std::uint8_t> chunk(kChunkBytes / element * element);
  std::uint64_t done = 0;
  while (done < count) {
    const std::size_t want =
        static_cast<std::size_t>(std::min<std::uint64_t>(chunk.size() / element, count - done));
    const std::size_t got = reader.read(chunk.data(), want * element);
    const std::size_t values = got / element;
    if (done + values > volume.data.capacity())
      volume.data.reserve(static_cast<std::size_t>(
          std::min<std::uint64_t>(count, std::max<std::uint64_t>(done + values, 2 * room))));
    room = volume.data.capacity();
    volume.data.resize(static_cast<std::size_t>(done + values));
    convert(chunk.data(), values, v, volume.data.data() + done);
    if (got < want * element) throw_short_data(v.path, need, done * element + got);
    done += want;
  }
  if (v.compression != Compression::none) finish_stream(reader);
  return volume;
}

// ---- dispatch ----

enum class FileFormat { nifti, metaimage, nrrd, dicom_file, unknown };

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

FileFormat format_of(const std::string& path) {
  std::string name = path;
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ends_with(name, ".nii") || ends_with(name, ".nii.gz")) return FileFormat::nifti;
  if (ends_with(name, ".mha") || ends_with(name, ".mhd")) return FileFormat::metaimage;
  if (ends_with(name, ".nrrd") || ends_with(name, ".nhdr")) return FileFormat::nrrd;
  if (ends_with(name, ".dcm")) return FileFormat::dicom_file;
  return FileFormat::unknown;
}

constexpr const char* kSupportedInputs =
    "a .nii, .nii.gz, .mha, .mhd, .nrrd or .nhdr file, a DICOM series directory, or phantom:NAME";

StoredImage read_header(const std::string& path) {
  switch (format_of(path)) {
    case FileFormat::nifti:
      return read_nifti_header(path);
    case FileFormat::metaimage:
      return read_metaimage_header(path);
    case FileFormat::nrrd:
      return read_nrrd_header(path);
    case FileFormat::dicom_file:
      throw InputError(path + ": a single DICOM file; give the directory that holds the series");
    case FileFormat::unknown:
      break;
  }
  throw InputError(path + ": unsupported input (expected " + kSupportedInputs + ")");
}

// Smallest and largest value (NaNs ignored), for the display range cal_min / cal_max.
template <class T>
std::pair<double, double> value_range(const std::vector<T>& data) {
  T lo = std::numeric_limits<T>::max();
  T hi = std::numeric_limits<T>::lowest();
  for (const T v : data) {
    lo = v < lo ? v : lo;
    hi = v > hi ? v : hi;
  }
  if (lo > hi) return {0.0, 0.0};
  return {static_cast<double>(lo), static_cast<double>(hi)};
}

template <class T>
void write_volume(const std::string& path, const Volume<T>& volume, ScalarType type) {
  const auto [lo, hi] = value_range(volume.data);
  const ByteSpan bytes(reinterpret_cast<const std::uint8_t*>(volume.data.data()),
                       volume.data.size() * sizeof(T));
  write_nifti_file(path, volume.grid, type, bytes, lo, hi);
}

}  // namespace

bool is_nifti_name(const std::string& path) {
  return format_of(path) == FileFormat::nifti;
}

std::string ct_voxel_file(const std::string& path) {
  return read_header(path).voxels.path;
}

CtVolume read_ct(const std::string& input) {
  const std::string phantom_prefix = "phantom:";
  if (input.rfind(phantom_prefix, 0) == 0) {
    const PhantomSpec spec = parse_phantom_spec(input.substr(phantom_prefix.size()));
    return make_phantom(spec.name, spec.options);
  }
  if (input.empty())
    throw InputError(std::string("no CT input given (expected ") + kSupportedInputs + ")");
  struct stat info {};
  if (::stat(input.c_str(), &info) != 0) {
    if (errno == ENOENT || errno == ENOTDIR)
      throw InputError(input + ": no such file or directory");
    if (errno == ELOOP) throw InputError(input + ": a loop of symbolic links");
    throw InputError(input + ": cannot access (" + std::strerror(errno) + ")");
  }
  if (S_ISDIR(info.st_mode)) return read_dicom_series(input);
  return load_volume<std::int16_t>(read_header(input));
}

void write_nifti(const std::string& path, const CtVolume& volume) {
  write_volume(path, volume, ScalarType::i16);
}

void write_nifti(const std::string& path, const Mask& volume) {
  write_volume(path, volume, ScalarType::u8);
}

void write_nifti(const std::string& path, const DistanceMap& volume) {
  write_volume(path, volume, ScalarType::f32);
}

void write_nifti(const std::string& path, const DistanceMap& volume, float lo, float hi) {
  const ByteSpan bytes(reinterpret_cast<const std::uint8_t*>(volume.data.data()),
                       volume.data.size() * sizeof(float));
  write_nifti_file(path, volume.grid, ScalarType::f32, bytes, lo, hi);
}

DistanceMap read_nifti_float(const std::string& path) {
  return load_volume<float>(read_nifti_header(path));
}

Mask read_nifti_mask(const std::string& path) {
  return load_volume<std::uint8_t>(read_nifti_header(path));
}

}  // namespace palp
