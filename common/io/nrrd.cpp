// NRRD header parsing. See nrrd.hpp.
#include "io/nrrd.hpp"

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <utility>

#include "base/errors.hpp"
#include "io/header_text.hpp"

namespace palp {
namespace {

namespace ht = header_text;

struct NrrdHeader {
  std::map<std::string, std::string> fields;
  std::map<std::string, std::string> key_values;
  std::uint64_t data_offset = 0;  // first byte after the blank line (attached data)
  bool has_blank_line = false;
};

InputError nrrd_error(const std::string& path, const std::string& message) {
  return InputError(path + ": " + message);
}

void check_magic(std::string_view first_line, const std::string& path) {
  const bool ok = first_line.size() == 8 && first_line.substr(0, 7) == "NRRD000" &&
                  first_line[7] >= '1' && first_line[7] <= '5';
  if (!ok)
    throw nrrd_error(path, "not a NRRD file (first line is \"" + ht::printable(first_line) +
                               "\", expected NRRD0001..NRRD0005)");
}

// A key:=value string with NRRD's two escapes decoded: "\n" (newline) and "\\" (backslash).
std::string unescape(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\\' && i + 1 < text.size() && (text[i + 1] == 'n' || text[i + 1] == '\\')) {
      out += text[i + 1] == 'n' ? '\n' : '\\';
      ++i;
    } else {
      out += text[i];
    }
  }
  return out;
}

// Reads the magic line and "field: value" lines up to the blank line (or the end of file).
NrrdHeader parse_nrrd_lines(const std::string& path) {
  const std::string head = ht::read_head(path, ht::kMaxHeaderBytes);
  NrrdHeader header;
  ht::LineCursor lines(head);
  std::string_view line;
  while (lines.next(line)) {
    if (lines.number() == 1) {
      check_magic(line, path);
      continue;
    }
    if (line.empty()) {
      header.data_offset = lines.offset();
      header.has_blank_line = true;
      return header;
    }
    if (line.front() == '#') continue;
    const std::size_t colon = line.find(": ");
    const std::size_t key_value = line.find(":=");
    if (key_value != std::string_view::npos &&
        (colon == std::string_view::npos || key_value < colon)) {
      header.key_values[unescape(line.substr(0, key_value))] = unescape(line.substr(key_value + 2));
      continue;
    }
    if (colon == std::string_view::npos)
      throw nrrd_error(path, "line " + std::to_string(lines.number()) + " is \"" +
                                 ht::printable(line) + "\", expected \"field: value\"");
    header.fields[std::string(line.substr(0, colon))] =
        std::string(ht::trim(line.substr(colon + 2)));
  }
  if (lines.number() == 0) throw nrrd_error(path, "file is empty");
  if (head.size() == ht::kMaxHeaderBytes) throw nrrd_error(path, "header is longer than 1 MiB");
  header.data_offset = head.size();
  return header;
}

// NRRD fields: the shared lookups.
class NrrdFields : public ht::HeaderFields {
 public:
  NrrdFields(const NrrdHeader& header, const std::string& path)
      : HeaderFields(header.fields, path, "missing field \"", "\"") {}
};

ScalarType scalar_type(const NrrdFields& f) {
  static const std::map<std::string, ScalarType> kTypes = {
      {"signed char", ScalarType::i8},
      {"int8", ScalarType::i8},
      {"int8_t", ScalarType::i8},
      {"uchar", ScalarType::u8},
      {"unsigned char", ScalarType::u8},
      {"uint8", ScalarType::u8},
      {"uint8_t", ScalarType::u8},
      {"short", ScalarType::i16},
      {"short int", ScalarType::i16},
      {"signed short", ScalarType::i16},
      {"signed short int", ScalarType::i16},
      {"int16", ScalarType::i16},
      {"int16_t", ScalarType::i16},
      {"ushort", ScalarType::u16},
      {"unsigned short", ScalarType::u16},
      {"unsigned short int", ScalarType::u16},
      {"uint16", ScalarType::u16},
      {"uint16_t", ScalarType::u16},
      {"int", ScalarType::i32},
      {"signed int", ScalarType::i32},
      {"int32", ScalarType::i32},
      {"int32_t", ScalarType::i32},
      {"uint", ScalarType::u32},
      {"unsigned int", ScalarType::u32},
      {"uint32", ScalarType::u32},
      {"uint32_t", ScalarType::u32},
      {"longlong", ScalarType::i64},
      {"long long", ScalarType::i64},
      {"long long int", ScalarType::i64},
      {"signed long long", ScalarType::i64},
      {"signed long long int", ScalarType::i64},
      {"int64", ScalarType::i64},
      {"int64_t", ScalarType::i64},
      {"ulonglong", ScalarType::u64},
      {"unsigned long long", ScalarType::u64},
      {"unsigned long long int", ScalarType::u64},
      {"uint64", ScalarType::u64},
      {"uint64_t", ScalarType::u64},
      {"float", ScalarType::f32},
      {"double", ScalarType::f64},
  };
  const std::string name = f.required("type");
  const auto it = kTypes.find(name);
  if (it == kTypes.end()) throw f.error("type \"" + ht::printable(name) + "\" is not supported");
  return it->second;
}

using Vector3 = std::array<double, 3>;

// Parses "(x,y,z) (x,y,z) ..." where an entry may also be "none".
std::optional<std::vector<std::optional<Vector3>>> parse_vectors(std::string_view text) {
  std::vector<std::optional<Vector3>> out;
  std::size_t i = 0;
  while (i < text.size()) {
    if (std::isspace(static_cast<unsigned char>(text[i]))) {
      ++i;
    } else if (text[i] == '(') {
      const std::size_t close = text.find(')', i);
      if (close == std::string_view::npos) return std::nullopt;
      const auto values = ht::finite_numbers(text.substr(i + 1, close - i - 1), 3, ",");
      if (!values) return std::nullopt;
      out.push_back(Vector3{(*values)[0], (*values)[1], (*values)[2]});
      i = close + 1;
    } else if (text.substr(i, 4) == "none") {
      out.push_back(std::nullopt);
      i += 4;
    } else {
      return std::nullopt;
    }
  }
  return out;
}

// Signs that take the named space's axes to LPS (x, y, z).
Vector3 to_lps_signs(const NrrdFields& f) {
  const auto space = f.find({"space"});
  if (!space) {
    if (const auto dim = f.find({"space dimension"}); dim && ht::to_int(*dim) != 3)
      throw f.error("space dimension " + ht::printable(*dim) + " is not supported (must be 3)");
    return {1, 1, 1};
  }
  const std::string s = ht::lower(*space);
  if (s == "left-posterior-superior" || s == "lps") return {1, 1, 1};
  if (s == "right-anterior-superior" || s == "ras") return {-1, -1, 1};
  if (s == "left-anterior-superior" || s == "las") return {1, -1, 1};
  if (s == "scanner-xyz" || s == "3d-right-handed" || s == "3d-left-handed") return {1, 1, 1};
  throw f.error("space \"" + ht::printable(*space) + "\" is not supported");
}

// Whether the file has a leading non-spatial axis (read_nrrd_layered_header): dimension 4 with
// the first kind not a spatial one.
int leading_axes(const NrrdFields& f, bool layered) {
  const std::string dimension = f.required("dimension");
  const auto n = ht::to_int(dimension);
  if (layered && n == 4) {
    if (const auto kinds = f.find({"kinds"})) {
      const auto parts = ht::tokens(*kinds);
      const std::string first = parts.empty() ? "" : ht::lower(parts[0]);
      if (parts.size() != 4 || first == "domain" || first == "space")
        throw f.error("kinds \"" + ht::printable(*kinds) +
                      "\" (a 4-D file needs a non-spatial first axis, such as \"list\")");
    }
    return 1;
  }
  if (n != 3)
    throw f.error("dimension " + ht::printable(dimension) + " is not supported (must be 3" +
                  (layered ? " or 4" : "") + ")");
  return 0;
}

// The spatial dims; `components` gets the length of the leading axis (1 without one).
Index3 sizes(const NrrdFields& f, int leading, std::int64_t& components) {
  const std::string text = f.required("sizes");
  const auto count = static_cast<std::size_t>(3 + leading);
  const auto values = ht::integers(text, count);
  if (!values)
    throw f.error("sizes \"" + ht::printable(text) + "\" is not " + std::to_string(count) +
                  " integers");
  components = leading ? (*values)[0] : 1;
  if (components < 1) throw f.error("sizes \"" + ht::printable(text) + "\": an axis is empty");
  return {(*values)[leading], (*values)[leading + 1], (*values)[leading + 2]};
}

// Spacing and world placement from "space directions" (+ "space origin") or "spacings"; after
// `leading` non-spatial axes (their direction "none", their spacing absent or NaN).
void geometry(const NrrdFields& f, Grid& grid, int leading) {
  const Vector3 sign = to_lps_signs(f);
  if (const auto origin_text = f.find({"space origin"})) {
    const auto origin = parse_vectors(*origin_text);
    if (!origin || origin->size() != 1 || !(*origin)[0])
      throw f.error("space origin \"" + ht::printable(*origin_text) + "\" is not (x,y,z)");
    for (int r = 0; r < 3; ++r) grid.world.origin[r] = sign[r] * (*(*origin)[0])[r];
  }
  if (const auto directions_text = f.find({"space directions"})) {
    const auto directions = parse_vectors(*directions_text);
    if (!directions || directions->size() != static_cast<std::size_t>(3 + leading) ||
        (leading && (*directions)[0]))
      throw f.error("space directions \"" + ht::printable(*directions_text) + "\" is not " +
                    (leading ? "\"none\" and " : "") + "three (x,y,z) vectors");
    for (int c = 0; c < 3; ++c) {
      const auto& v = (*directions)[c + leading];
      if (!v) throw f.error("space directions: axis " + std::to_string(c) + " is \"none\"");
      const double norm = std::sqrt((*v)[0] * (*v)[0] + (*v)[1] * (*v)[1] + (*v)[2] * (*v)[2]);
      if (!(norm > 0.0)) throw f.error("space directions: axis " + std::to_string(c) + " is zero");
      grid.spacing[c] = norm;
      for (int r = 0; r < 3; ++r) grid.world.direction[r * 3 + c] = sign[r] * (*v)[r] / norm;
    }
    return;
  }
  if (const auto spacings_text = f.find({"spacings"})) {
    std::string_view text = *spacings_text;
    if (leading) {  // the leading axis has no spacing: "nan" (or any one token) before the three
      const auto parts = ht::tokens(text);
      if (!parts.empty()) text = text.substr(parts[0].data() + parts[0].size() - text.data());
    }
    const auto spacings = ht::finite_numbers(text, 3);
    if (!spacings)
      throw f.error("spacings \"" + ht::printable(*spacings_text) + "\" is not 3 finite numbers");
    for (int a = 0; a < 3; ++a) grid.spacing[a] = std::fabs((*spacings)[a]);
  }
}

Compression encoding(const NrrdFields& f) {
  const std::string name = ht::lower(f.required("encoding"));
  if (name == "raw") return Compression::none;
  if (name == "gzip" || name == "gz") return Compression::gzip;
  throw f.error("encoding " + ht::printable(name) + " not supported (raw and gzip are)");
}

bool big_endian(const NrrdFields& f) {
  const auto endian = f.find({"endian"});
  if (!endian) return false;
  const std::string e = ht::lower(*endian);
  if (e == "big") return true;
  if (e == "little") return false;
  throw f.error("endian \"" + ht::printable(*endian) + "\" is not little or big");
}

std::int64_t integer_field(const NrrdFields& f, const char* key, std::int64_t min_value) {
  const auto text = f.find({key});
  if (!text) return 0;
  const auto value = ht::to_int(*text);
  if (!value || *value < min_value)
    throw f.error(std::string(key) + " \"" + ht::printable(*text) + "\" is not usable");
  return *value;
}

// Offset of the byte after `lines` newlines counted from `offset` in the file.
std::uint64_t skip_lines(const std::string& path, std::uint64_t offset, std::int64_t lines) {
  DecodedReader reader(path, offset, Compression::none);
  std::vector<char> buffer(1 << 16);
  std::uint64_t position = offset;
  while (lines > 0) {
    const std::size_t got = reader.read(buffer.data(), buffer.size());
    if (got == 0) throw nrrd_error(path, "line skip goes past the end of the file");
    for (std::size_t i = 0; i < got && lines > 0; ++i, ++position)
      if (buffer[i] == '\n') --lines;
  }
  return position;
}

void locate_voxels(const NrrdFields& f, const NrrdHeader& header, StoredVoxels& voxels) {
  const std::string& path = f.path();
  if (const auto data_file = f.find({"data file", "datafile"})) {
    if (*data_file == "LIST" || data_file->rfind("LIST ", 0) == 0 ||
        data_file->find('%') != std::string::npos)
      throw f.error("multi-file data (data file: " + ht::printable(*data_file) +
                    ") is not supported");
    voxels.path = ht::beside(path, *data_file);
    voxels.file_offset = 0;
    ht::require_data_file(f, voxels.path);
  } else {
    if (!header.has_blank_line)
      throw f.error("no data (no blank line after the header and no data file)");
    voxels.path = path;
    voxels.file_offset = header.data_offset;
  }
  voxels.compression = encoding(f);
  const std::int64_t line_skip = integer_field(f, "line skip", 0);
  if (line_skip > 0) voxels.file_offset = skip_lines(voxels.path, voxels.file_offset, line_skip);
  const std::int64_t byte_skip = integer_field(f, "byte skip", -1);
  if (byte_skip == -1) {
    if (voxels.compression != Compression::none) throw f.error("byte skip -1 needs raw encoding");
    voxels.at_end_of_file = true;
  } else {
    voxels.skip = static_cast<std::uint64_t>(byte_skip);
  }
}

NrrdLayeredImage read_layered(const std::string& path, bool layered) {
  NrrdHeader header = parse_nrrd_lines(path);
  const NrrdFields f(header, path);

  NrrdLayeredImage out;
  StoredImage& image = out.image;
  const int leading = leading_axes(f, layered);
  image.grid.dims = sizes(f, leading, out.components);
  geometry(f, image.grid, leading);
  validate_grid(image.grid, path);
  if (out.components > kMaxVoxelsPerAxis)
    throw f.error("sizes: " + std::to_string(out.components) + " values per voxel (at most " +
                  std::to_string(kMaxVoxelsPerAxis) + ")");

  StoredVoxels& voxels = image.voxels;
  voxels.type = scalar_type(f);
  voxels.big_endian = big_endian(f);
  locate_voxels(f, header, voxels);
  out.key_values = std::move(header.key_values);
  return out;
}

}  // namespace

StoredImage read_nrrd_header(const std::string& path) {
  return read_layered(path, false).image;
}

NrrdLayeredImage read_nrrd_layered_header(const std::string& path) {
  return read_layered(path, true);
}

}  // namespace palp
