// What a volume file's header says: the grid, and where and how its voxels are stored. The
// NIfTI, MetaImage and NRRD parsers produce a StoredImage; ct_io.cpp turns one into a volume.
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>

#include "base/volume.hpp"
#include "io/gzip.hpp"

namespace palp {

enum class ScalarType { u8, i8, u16, i16, u32, i32, u64, i64, f32, f64 };

constexpr std::size_t scalar_size(ScalarType type) {
  switch (type) {
    case ScalarType::u8:
    case ScalarType::i8:
      return 1;
    case ScalarType::u16:
    case ScalarType::i16:
      return 2;
    case ScalarType::u32:
    case ScalarType::i32:
    case ScalarType::f32:
      return 4;
    case ScalarType::u64:
    case ScalarType::i64:
    case ScalarType::f64:
      return 8;
  }
  return 0;
}

constexpr const char* scalar_name(ScalarType type) {
  switch (type) {
    case ScalarType::u8:
      return "uint8";
    case ScalarType::i8:
      return "int8";
    case ScalarType::u16:
      return "uint16";
    case ScalarType::i16:
      return "int16";
    case ScalarType::u32:
      return "uint32";
    case ScalarType::i32:
      return "int32";
    case ScalarType::u64:
      return "uint64";
    case ScalarType::i64:
      return "int64";
    case ScalarType::f32:
      return "float32";
    case ScalarType::f64:
      return "float64";
  }
  return "?";
}

// A scalar with its bytes in the opposite order (any trivially copyable T).
template <class T>
T byte_swapped(T value) {
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  for (std::size_t a = 0, b = sizeof(T) - 1; a < b; ++a, --b) std::swap(bytes[a], bytes[b]);
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

constexpr bool kHostIsBigEndian = std::endian::native == std::endian::big;

// Where the voxels are: `path` from byte `file_offset` on is a stream (raw or compressed);
// after `skip` decoded bytes come the voxels, i fastest. value = stored * slope + intercept.
struct StoredVoxels {
  std::string path;
  std::uint64_t file_offset = 0;
  Compression compression = Compression::none;
  std::uint64_t skip = 0;
  bool at_end_of_file = false;  // raw voxels are the last bytes of the file (skip ignored)
  ScalarType type = ScalarType::i16;
  bool big_endian = false;
  double slope = 1.0;
  double intercept = 0.0;
};

struct StoredImage {
  Grid grid;  // dims, spacing, world placement (LPS)
  StoredVoxels voxels;
};

}  // namespace palp
