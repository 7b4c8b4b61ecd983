// NIfTI-1 header parsing and writing. See nifti.hpp.
#include "io/nifti.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <optional>

#include "base/errors.hpp"

namespace palp {
namespace {

// The 348-byte NIfTI-1 header, laid out as the standard defines it (no padding).
struct NiftiHeader {
  std::int32_t sizeof_hdr;
  char data_type[10];
  char db_name[18];
  std::int32_t extents;
  std::int16_t session_error;
  char regular;
  char dim_info;
  std::int16_t dim[8];
  float intent_p1;
  float intent_p2;
  float intent_p3;
  std::int16_t intent_code;
  std::int16_t datatype;
  std::int16_t bitpix;
  std::int16_t slice_start;
  float pixdim[8];
  float vox_offset;
  float scl_slope;
  float scl_inter;
  std::int16_t slice_end;
  char slice_code;
  char xyzt_units;
  float cal_max;
  float cal_min;
  float slice_duration;
  float toffset;
  std::int32_t glmax;
  std::int32_t glmin;
  char descrip[80];
  char aux_file[24];
  std::int16_t qform_code;
  std::int16_t sform_code;
  float quatern_b;
  float quatern_c;
  float quatern_d;
  float qoffset_x;
  float qoffset_y;
  float qoffset_z;
  float srow_x[4];
  float srow_y[4];
  float srow_z[4];
  char intent_name[16];
  char magic[4];
};
static_assert(sizeof(NiftiHeader) == 348);
static_assert(offsetof(NiftiHeader, dim) == 40);
static_assert(offsetof(NiftiHeader, datatype) == 70);
static_assert(offsetof(NiftiHeader, pixdim) == 76);
static_assert(offsetof(NiftiHeader, vox_offset) == 108);
static_assert(offsetof(NiftiHeader, cal_max) == 124);
static_assert(offsetof(NiftiHeader, qform_code) == 252);
static_assert(offsetof(NiftiHeader, srow_x) == 280);
static_assert(offsetof(NiftiHeader, magic) == 344);

constexpr std::int32_t kHeaderBytes = 348;
constexpr std::int32_t kNifti2HeaderBytes = 540;
constexpr float kVoxOffset = 352.0f;  // header + 4-byte extension flag
constexpr char kXyztUnitsMm = 2;

template <class T, std::size_t N>
void swap_all(T (&values)[N]) {
  for (T& v : values) v = byte_swapped(v);
}

template <class T>
void swap_one(T& value) {
  value = byte_swapped(value);
}

void swap_header(NiftiHeader& h) {
  swap_one(h.sizeof_hdr);
  swap_one(h.extents);
  swap_one(h.session_error);
  swap_all(h.dim);
  swap_one(h.intent_p1);
  swap_one(h.intent_p2);
  swap_one(h.intent_p3);
  swap_one(h.intent_code);
  swap_one(h.datatype);
  swap_one(h.bitpix);
  swap_one(h.slice_start);
  swap_all(h.pixdim);
  swap_one(h.vox_offset);
  swap_one(h.scl_slope);
  swap_one(h.scl_inter);
  swap_one(h.slice_end);
  swap_one(h.cal_max);
  swap_one(h.cal_min);
  swap_one(h.slice_duration);
  swap_one(h.toffset);
  swap_one(h.glmax);
  swap_one(h.glmin);
  swap_one(h.qform_code);
  swap_one(h.sform_code);
  swap_one(h.quatern_b);
  swap_one(h.quatern_c);
  swap_one(h.quatern_d);
  swap_one(h.qoffset_x);
  swap_one(h.qoffset_y);
  swap_one(h.qoffset_z);
  swap_all(h.srow_x);
  swap_all(h.srow_y);
  swap_all(h.srow_z);
}

// NIfTI datatype codes.
std::optional<ScalarType> scalar_from_datatype(int code) {
  switch (code) {
    case 2:
      return ScalarType::u8;
    case 4:
      return ScalarType::i16;
    case 8:
      return ScalarType::i32;
    case 16:
      return ScalarType::f32;
    case 64:
      return ScalarType::f64;
    case 256:
      return ScalarType::i8;
    case 512:
      return ScalarType::u16;
    case 768:
      return ScalarType::u32;
    case 1024:
      return ScalarType::i64;
    case 1280:
      return ScalarType::u64;
    default:
      return std::nullopt;
  }
}

std::int16_t datatype_code(ScalarType type) {
  switch (type) {
    case ScalarType::u8:
      return 2;
    case ScalarType::i16:
      return 4;
    case ScalarType::f32:
      return 16;
    default:
      throw UsageError(std::string("NIfTI writer: unsupported voxel type ") + scalar_name(type));
  }
}

const char* datatype_name(int code) {
  switch (code) {
    case 1:
      return "binary";
    case 32:
      return "complex64";
    case 128:
      return "RGB24";
    case 1536:
      return "float128";
    case 1792:
      return "complex128";
    case 2048:
      return "complex256";
    case 2304:
      return "RGBA32";
    default:
      return "unknown";
  }
}

// A 3x4 affine: rows x, y, z; columns i, j, k axes and the translation.
using Affine = std::array<std::array<double, 4>, 3>;

bool finite_affine(const Affine& a) {
  for (const auto& row : a)
    for (double v : row)
      if (!std::isfinite(v)) return false;
  return true;
}

double column_norm(const Affine& a, int c) {
  return std::sqrt(a[0][c] * a[0][c] + a[1][c] * a[1][c] + a[2][c] * a[2][c]);
}

bool usable_affine(const Affine& a) {
  if (!finite_affine(a)) return false;
  for (int c = 0; c < 3; ++c)
    if (!(column_norm(a, c) > 0.0)) return false;
  return true;
}

Affine sform_affine(const NiftiHeader& h) {
  Affine a{};
  for (int c = 0; c < 4; ++c) {
    a[0][c] = h.srow_x[c];
    a[1][c] = h.srow_y[c];
    a[2][c] = h.srow_z[c];
  }
  return a;
}

using Rotation = std::array<std::array<double, 3>, 3>;

// Rotation of the unit quaternion (a, b, c, d), with a recovered from b, c, d as NIfTI does.
Rotation rotation_from_quaternion(double b, double c, double d) {
  double a = 1.0 - (b * b + c * c + d * d);
  if (a < 1e-7) {  // not a unit quaternion: normalise (b, c, d), a 180 degree rotation
    const double n = std::sqrt(b * b + c * c + d * d);
    b /= n;
    c /= n;
    d /= n;
    a = 0.0;
  } else {
    a = std::sqrt(a);
  }
  return {{{a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
           {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
           {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b}}};
}

Affine qform_affine(const NiftiHeader& h, const Vec3& spacing) {
  const Rotation r = rotation_from_quaternion(h.quatern_b, h.quatern_c, h.quatern_d);
  const double qfac = h.pixdim[0] < 0 ? -1.0 : 1.0;
  const Vec3 scale{spacing[0], spacing[1], spacing[2] * qfac};
  const Vec3 offset{h.qoffset_x, h.qoffset_y, h.qoffset_z};
  Affine a{};
  for (int row = 0; row < 3; ++row) {
    for (int c = 0; c < 3; ++c) a[row][c] = r[row][c] * scale[c];
    a[row][3] = offset[row];
  }
  return a;
}

Affine scaled_identity_affine(const Vec3& spacing) {
  Affine a{};
  for (int row = 0; row < 3; ++row) a[row][row] = spacing[row];
  return a;
}

// RAS affine -> LPS world placement with unit direction columns ("+ 0.0" turns -0 into 0).
WorldPlacement world_from_ras_affine(const Affine& a) {
  WorldPlacement world;
  const double flip[3] = {-1.0, -1.0, 1.0};
  for (int c = 0; c < 3; ++c) {
    const double norm = column_norm(a, c);
    for (int row = 0; row < 3; ++row)
      world.direction[row * 3 + c] = flip[row] * a[row][c] / norm + 0.0;
  }
  for (int row = 0; row < 3; ++row) world.origin[row] = flip[row] * a[row][3] + 0.0;
  return world;
}

WorldPlacement read_world(const NiftiHeader& h, const Vec3& spacing) {
  if (h.sform_code > 0) {
    const Affine a = sform_affine(h);
    if (usable_affine(a)) return world_from_ras_affine(a);
  }
  if (h.qform_code > 0) {
    const Affine a = qform_affine(h, spacing);
    if (usable_affine(a)) return world_from_ras_affine(a);
  }
  return world_from_ras_affine(scaled_identity_affine(spacing));
}

// Reads the 348 header bytes into host byte order; `swapped` tells whether the file's order
// differs from the host's.
NiftiHeader read_raw_header(const std::string& path, bool& swapped, Compression& compression) {
  compression = file_is_gzip(path) ? Compression::gzip : Compression::none;
  DecodedReader reader(path, 0, compression);
  NiftiHeader h{};
  const std::size_t got = reader.read(&h, sizeof h);
  if (got < sizeof h)
    throw InputError(path + ": not a NIfTI-1 file (only " + std::to_string(got) +
                     " header bytes, 348 needed)");
  swapped = false;
  if (h.sizeof_hdr != kHeaderBytes) {
    const std::int32_t other = byte_swapped(h.sizeof_hdr);
    if (other == kHeaderBytes) {
      swapped = true;
      swap_header(h);
    } else if (h.sizeof_hdr == kNifti2HeaderBytes || other == kNifti2HeaderBytes) {
      throw InputError(path + ": NIfTI-2 files are not supported (convert to NIfTI-1)");
    } else {
      throw InputError(path + ": not a NIfTI-1 file (sizeof_hdr is " +
                       std::to_string(h.sizeof_hdr) + ", expected 348)");
    }
  }
  return h;
}

void check_magic(const NiftiHeader& h, const std::string& path) {
  if (std::memcmp(h.magic, "n+1\0", 4) == 0) return;
  if (std::memcmp(h.magic, "ni1\0", 4) == 0)
    throw InputError(path + ": NIfTI-1 header/image pairs (.hdr/.img) are not supported");
  throw InputError(path + ": not a single-file NIfTI-1 image (magic is not \"n+1\")");
}

Index3 read_dims(const NiftiHeader& h, const std::string& path) {
  const int ndim = h.dim[0];
  if (ndim < 1 || ndim > 7)
    throw InputError(path + ": dim[0] is " + std::to_string(ndim) + " (must be 1..7)");
  Index3 dims{1, 1, 1};
  for (int a = 0; a < std::min(ndim, 3); ++a) dims[a] = h.dim[a + 1];
  for (int a = 4; a <= ndim; ++a) {
    if (h.dim[a] != 1)
      throw InputError(path + ": a " + std::to_string(ndim) + "-D image with dim[" +
                       std::to_string(a) + "] = " + std::to_string(h.dim[a]) +
                       " (only 3-D volumes are supported)");
  }
  return dims;
}

Vec3 read_spacing(const NiftiHeader& h) {
  Vec3 spacing{1.0, 1.0, 1.0};
  for (int a = 0; a < std::min<int>(h.dim[0], 3); ++a) spacing[a] = std::fabs(h.pixdim[a + 1]);
  return spacing;
}

std::uint64_t read_vox_offset(const NiftiHeader& h, const std::string& path) {
  const double offset = h.vox_offset;
  if (!std::isfinite(offset) || offset < 0.0 || offset > 1e12 || offset != std::floor(offset))
    throw InputError(path + ": vox_offset " + std::to_string(offset) + " is not usable");
  // Like other readers, treat an offset inside the header as "right after it".
  return offset < kHeaderBytes ? static_cast<std::uint64_t>(kVoxOffset)
                               : static_cast<std::uint64_t>(offset);
}

void read_scaling(const NiftiHeader& h, StoredVoxels& voxels) {
  const double slope = h.scl_slope;
  if (std::isfinite(slope) && slope != 0.0) {
    voxels.slope = slope;
    voxels.intercept = std::isfinite(h.scl_inter) ? h.scl_inter : 0.0;
  }
}

// ---- writing ----

struct Quaternion {
  double a, b, c, d;
};

// Shepperd's method: the quaternion of a rotation matrix, a >= 0.
Quaternion quaternion_from_rotation(const Rotation& r) {
  Quaternion q{};
  const double trace = r[0][0] + r[1][1] + r[2][2];
  if (trace > 0.0) {
    const double s = 0.5 / std::sqrt(trace + 1.0);
    q = {0.25 / s, (r[2][1] - r[1][2]) * s, (r[0][2] - r[2][0]) * s, (r[1][0] - r[0][1]) * s};
  } else if (r[0][0] > r[1][1] && r[0][0] > r[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + r[0][0] - r[1][1] - r[2][2]);
    q = {(r[2][1] - r[1][2]) / s, 0.25 * s, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s};
  } else if (r[1][1] > r[2][2]) {
    const double s = 2.0 * std::sqrt(1.0 + r[1][1] - r[0][0] - r[2][2]);
    q = {(r[0][2] - r[2][0]) / s, (r[0][1] + r[1][0]) / s, 0.25 * s, (r[1][2] + r[2][1]) / s};
  } else {
    const double s = 2.0 * std::sqrt(1.0 + r[2][2] - r[0][0] - r[1][1]);
    q = {(r[1][0] - r[0][1]) / s, (r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, 0.25 * s};
  }
  const double n = std::sqrt(q.a * q.a + q.b * q.b + q.c * q.c + q.d * q.d);
  const double sign = q.a < 0.0 ? -1.0 : 1.0;
  return {sign * q.a / n, sign * q.b / n, sign * q.c / n, sign * q.d / n};
}

double determinant(const Rotation& r) {
  return r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) -
         r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
         r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
}

// Grid::world (LPS) -> RAS direction matrix and origin ("+ 0.0" turns -0 into 0).
Rotation ras_direction(const WorldPlacement& world) {
  const double flip[3] = {-1.0, -1.0, 1.0};
  Rotation r{};
  for (int row = 0; row < 3; ++row)
    for (int c = 0; c < 3; ++c) r[row][c] = flip[row] * world.direction[row * 3 + c] + 0.0;
  return r;
}

Vec3 ras_origin(const WorldPlacement& world) {
  return {-world.origin[0] + 0.0, -world.origin[1] + 0.0, world.origin[2]};
}

void write_qform(NiftiHeader& h, const Rotation& ras, const Vec3& origin) {
  Rotation r = ras;
  double qfac = 1.0;
  if (determinant(r) < 0.0) {  // a reflection: NIfTI stores it as qfac = -1 on the k axis
    qfac = -1.0;
    for (auto& row : r) row[2] = -row[2];
  }
  const Quaternion q = quaternion_from_rotation(r);
  h.qform_code = 1;  // NIFTI_XFORM_SCANNER_ANAT
  h.pixdim[0] = static_cast<float>(qfac);
  h.quatern_b = static_cast<float>(q.b);
  h.quatern_c = static_cast<float>(q.c);
  h.quatern_d = static_cast<float>(q.d);
  h.qoffset_x = static_cast<float>(origin[0]);
  h.qoffset_y = static_cast<float>(origin[1]);
  h.qoffset_z = static_cast<float>(origin[2]);
}

void write_sform(NiftiHeader& h, const Rotation& ras, const Vec3& origin, const Vec3& spacing) {
  float* rows[3] = {h.srow_x, h.srow_y, h.srow_z};
  for (int row = 0; row < 3; ++row) {
    for (int c = 0; c < 3; ++c) rows[row][c] = static_cast<float>(ras[row][c] * spacing[c]);
    rows[row][3] = static_cast<float>(origin[row]);
  }
  h.sform_code = 1;  // NIFTI_XFORM_SCANNER_ANAT
}

NiftiHeader make_header(const Grid& grid, ScalarType type, double cal_min, double cal_max) {
  NiftiHeader h{};
  h.sizeof_hdr = kHeaderBytes;
  h.regular = 'r';
  h.dim[0] = 3;
  for (int a = 0; a < 3; ++a) h.dim[a + 1] = static_cast<std::int16_t>(grid.dims[a]);
  for (int a = 4; a < 8; ++a) h.dim[a] = 1;
  h.datatype = datatype_code(type);
  h.bitpix = static_cast<std::int16_t>(8 * scalar_size(type));
  for (int a = 0; a < 3; ++a) h.pixdim[a + 1] = static_cast<float>(grid.spacing[a]);
  for (int a = 4; a < 8; ++a) h.pixdim[a] = 1.0f;
  h.vox_offset = kVoxOffset;
  h.scl_slope = 1.0f;
  h.scl_inter = 0.0f;
  h.xyzt_units = kXyztUnitsMm;
  h.cal_min = static_cast<float>(cal_min);
  h.cal_max = static_cast<float>(cal_max);
  std::strncpy(h.descrip, "palp", sizeof h.descrip);
  const Rotation ras = ras_direction(grid.world);
  const Vec3 origin = ras_origin(grid.world);
  write_qform(h, ras, origin);
  write_sform(h, ras, origin, grid.spacing);
  std::memcpy(h.magic, "n+1\0", 4);
  return h;
}

}  // namespace

bool has_gz_suffix(const std::string& path) {
  if (path.size() < 3) return false;
  const std::string tail = path.substr(path.size() - 3);
  return tail[0] == '.' && std::tolower(static_cast<unsigned char>(tail[1])) == 'g' &&
         std::tolower(static_cast<unsigned char>(tail[2])) == 'z';
}

StoredImage read_nifti_header(const std::string& path) {
  bool swapped = false;
  Compression compression = Compression::none;
  const NiftiHeader h = read_raw_header(path, swapped, compression);
  check_magic(h, path);

  StoredImage image;
  image.grid.dims = read_dims(h, path);
  image.grid.spacing = read_spacing(h);
  validate_grid(image.grid, path);
  image.grid.world = read_world(h, image.grid.spacing);

  const auto type = scalar_from_datatype(h.datatype);
  if (!type)
    throw InputError(path + ": NIfTI datatype " + std::to_string(h.datatype) + " (" +
                     datatype_name(h.datatype) + ") is not supported");
  StoredVoxels& voxels = image.voxels;
  voxels.path = path;
  voxels.compression = compression;
  voxels.file_offset = 0;
  voxels.skip = read_vox_offset(h, path);
  voxels.type = *type;
  voxels.big_endian = swapped != kHostIsBigEndian;
  read_scaling(h, voxels);
  return image;
}

void write_nifti_file(const std::string& path, const Grid& grid, ScalarType type, ByteSpan voxels,
                      double cal_min, double cal_max) {
  validate_grid(grid, path);
  if (voxels.size() != grid.voxel_count() * scalar_size(type))
    throw UsageError(path + ": voxel buffer does not match the grid");
  for (int a = 0; a < 3; ++a) {
    if (grid.dims[a] > 32767)
      throw UsageError(path + ": NIfTI-1 cannot store more than 32767 voxels along an axis");
  }
  NiftiHeader h = make_header(grid, type, cal_min, cal_max);
  std::array<std::uint8_t, static_cast<std::size_t>(kVoxOffset)> head{};  // header + extension flag
  std::memcpy(head.data(), &h, sizeof h);
  const ByteSpan pieces[2] = {ByteSpan(head.data(), head.size()), voxels};
  write_file(path, pieces, has_gz_suffix(path));
}

}  // namespace palp
