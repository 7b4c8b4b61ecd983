// MetaImage header parsing. See metaimage.hpp.
#include "io/metaimage.hpp"

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>

#include "base/errors.hpp"
#include "io/header_text.hpp"

namespace palp {
namespace {

namespace ht = header_text;

struct MetaHeader {
  std::map<std::string, std::string> fields;
  std::uint64_t data_offset = 0;  // first byte after the ElementDataFile line
};

// Reads "Key = Value" lines up to and including ElementDataFile.
MetaHeader parse_meta_lines(const std::string& path) {
  const std::string head = ht::read_head(path, ht::kMaxHeaderBytes);
  MetaHeader header;
  ht::LineCursor lines(head);
  std::string_view raw;
  while (lines.next(raw)) {
    const std::string_view line = ht::trim(raw);
    if (line.empty()) continue;
    const std::size_t eq = line.find('=');
    if (eq == std::string_view::npos)
      throw InputError(path + ": not a MetaImage header (line " + std::to_string(lines.number()) +
                       " is \"" + ht::printable(line) + "\", expected \"Key = Value\")");
    const std::string key(ht::trim(line.substr(0, eq)));
    header.fields[key] = std::string(ht::trim(line.substr(eq + 1)));
    if (key == "ElementDataFile") {
      header.data_offset = lines.offset();
      return header;
    }
  }
  throw InputError(path + ": MetaImage header has no ElementDataFile line" +
                   (head.size() == ht::kMaxHeaderBytes ? " in its first 1 MiB" : ""));
}

// MetaImage fields: the shared lookups plus the MetaImage value forms (number lists, booleans).
class MetaFields : public ht::HeaderFields {
 public:
  MetaFields(const MetaHeader& header, const std::string& path)
      : HeaderFields(header.fields, path, "missing ", "") {}

  std::vector<double> numbers(std::initializer_list<const char*> keys, std::size_t count,
                              std::vector<double> fallback) const {
    for (const char* key : keys) {
      const auto value = find({key});
      if (!value) continue;
      const auto parsed = ht::finite_numbers(*value, count);
      if (!parsed)
        throw error(std::string(key) + " = \"" + ht::printable(*value) + "\" is not " +
                    std::to_string(count) + " finite numbers");
      return *parsed;
    }
    return fallback;
  }

  bool boolean(std::initializer_list<const char*> keys, bool fallback) const {
    for (const char* key : keys) {
      const auto value = find({key});
      if (!value) continue;
      const std::string v = ht::lower(*value);
      if (v == "true" || v == "1") return true;
      if (v == "false" || v == "0") return false;
      throw error(std::string(key) + " = \"" + ht::printable(*value) + "\" is not True or False");
    }
    return fallback;
  }
};

ScalarType element_type(const MetaFields& f) {
  static const std::map<std::string, ScalarType> kTypes = {
      {"MET_UCHAR", ScalarType::u8},       {"MET_CHAR", ScalarType::i8},
      {"MET_USHORT", ScalarType::u16},     {"MET_SHORT", ScalarType::i16},
      {"MET_UINT", ScalarType::u32},       {"MET_INT", ScalarType::i32},
      {"MET_ULONG", ScalarType::u32},      {"MET_LONG", ScalarType::i32},
      {"MET_ULONG_LONG", ScalarType::u64}, {"MET_LONG_LONG", ScalarType::i64},
      {"MET_FLOAT", ScalarType::f32},      {"MET_DOUBLE", ScalarType::f64}};
  const std::string name = f.required("ElementType");
  const auto it = kTypes.find(name);
  if (it == kTypes.end()) throw f.error("ElementType " + ht::printable(name) + " is not supported");
  return it->second;
}

void check_image_kind(const MetaFields& f) {
  if (const auto type = f.find({"ObjectType"}); type && *type != "Image")
    throw f.error("ObjectType is " + ht::printable(*type) + ", not Image");
  const std::string ndims = f.required("NDims");
  if (ht::to_int(ndims) != 3)
    throw f.error("NDims is " + ht::printable(ndims) + " (only 3-D images are supported)");
  if (const auto channels = f.find({"ElementNumberOfChannels"});
      channels && ht::to_int(*channels) != 1)
    throw f.error("ElementNumberOfChannels " + ht::printable(*channels) +
                  " is not supported (scalar images only)");
  if (!f.boolean({"BinaryData"}, true))
    throw f.error("ASCII data (BinaryData = False) is not supported");
}

Index3 dim_size(const MetaFields& f) {
  const std::string text = f.required("DimSize");
  const auto dims = ht::integers(text, 3);
  if (!dims) throw f.error("DimSize = \"" + ht::printable(text) + "\" is not 3 integers");
  return {(*dims)[0], (*dims)[1], (*dims)[2]};
}

// TransformMatrix lists axis directions one after the other: element (c*3 + r) is row r of
// direction column c.
WorldPlacement world_placement(const MetaFields& f) {
  WorldPlacement world;
  const auto origin = f.numbers({"Offset", "Origin", "Position"}, 3, {0, 0, 0});
  const auto matrix =
      f.numbers({"TransformMatrix", "Rotation", "Orientation"}, 9, {1, 0, 0, 0, 1, 0, 0, 0, 1});
  for (int c = 0; c < 3; ++c) {
    const double norm =
        std::sqrt(matrix[c * 3] * matrix[c * 3] + matrix[c * 3 + 1] * matrix[c * 3 + 1] +
                  matrix[c * 3 + 2] * matrix[c * 3 + 2]);
    if (!(norm > 0.0)) throw f.error("TransformMatrix has a zero axis direction");
    for (int r = 0; r < 3; ++r) world.direction[r * 3 + c] = matrix[c * 3 + r] / norm;
  }
  for (int r = 0; r < 3; ++r) world.origin[r] = origin[r];
  return world;
}

void locate_voxels(const MetaFields& f, const MetaHeader& header, const std::string& path,
                   StoredVoxels& voxels) {
  const std::string data_file = f.required("ElementDataFile");
  voxels.compression = f.boolean({"CompressedData"}, false) ? Compression::zlib : Compression::none;
  const std::string keyword = ht::lower(data_file);
  if (keyword == "local") {
    voxels.path = path;
    voxels.file_offset = header.data_offset;
    return;
  }
  if (keyword == "list" || keyword.rfind("list ", 0) == 0 ||
      data_file.find('%') != std::string::npos)
    throw f.error("multi-file data (ElementDataFile = " + ht::printable(data_file) +
                  ") is not supported");
  voxels.path = ht::beside(path, data_file);
  ht::require_data_file(f, voxels.path);
  if (const auto header_size = f.find({"HeaderSize"})) {
    const auto skip = ht::to_int(*header_size);
    if (!skip || *skip < -1)
      throw f.error("HeaderSize = \"" + ht::printable(*header_size) + "\" is not usable");
    if (*skip == -1) {
      if (voxels.compression != Compression::none)
        throw f.error("HeaderSize = -1 needs uncompressed data");
      voxels.at_end_of_file = true;
    } else {
      voxels.file_offset = static_cast<std::uint64_t>(*skip);
    }
  }
}

}  // namespace

StoredImage read_metaimage_header(const std::string& path) {
  const MetaHeader header = parse_meta_lines(path);
  const MetaFields f(header, path);
  check_image_kind(f);

  StoredImage image;
  image.grid.dims = dim_size(f);
  const auto spacing = f.numbers({"ElementSpacing", "ElementSize"}, 3, {1, 1, 1});
  image.grid.spacing = {spacing[0], spacing[1], spacing[2]};
  validate_grid(image.grid, path);
  image.grid.world = world_placement(f);

  StoredVoxels& voxels = image.voxels;
  voxels.type = element_type(f);
  voxels.big_endian = f.boolean({"BinaryDataByteOrderMSB", "ElementByteOrderMSB"}, false);
  locate_voxels(f, header, path, voxels);
  return image;
}

}  // namespace palp
