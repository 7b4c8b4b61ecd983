// Small helpers shared by the text-header parsers (MetaImage, NRRD): reading a file's head,
// splitting lines, strict number parsing, and paths relative to a header.
#pragma once

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/errors.hpp"
#include "io/gzip.hpp"

namespace palp::header_text {

// How much of a file a text header may take: the parsers read at most this much before the data
// (their messages say "1 MiB").
inline constexpr std::size_t kMaxHeaderBytes = std::size_t{1} << 20;

// The first `max_bytes` of a file (fewer if the file is shorter).
inline std::string read_head(const std::string& path, std::size_t max_bytes) {
  DecodedReader reader(path, 0, Compression::none);
  std::string head(max_bytes, '\0');
  head.resize(reader.read(head.data(), head.size()));
  return head;
}

inline std::string_view trim(std::string_view s) {
  const auto is_space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

inline std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// Walks a header line by line: next() gives the next line (without its '\n' or a trailing '\r'),
// offset() the first byte after it and number() its 1-based line number; false at the end.
class LineCursor {
 public:
  explicit LineCursor(std::string_view head) : head_(head) {}
  bool next(std::string_view& line) {
    if (pos_ >= head_.size()) return false;
    std::size_t eol = head_.find('\n', pos_);
    const std::size_t next = eol == std::string_view::npos ? head_.size() : eol + 1;
    if (eol == std::string_view::npos) eol = head_.size();
    line = head_.substr(pos_, eol - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = next;
    ++number_;
    return true;
  }
  std::size_t offset() const { return pos_; }
  int number() const { return number_; }

 private:
  std::string_view head_;
  std::size_t pos_ = 0;
  int number_ = 0;
};

// A line of the header shown in an error message: printable characters only, shortened.
inline std::string printable(std::string_view s) {
  std::string out;
  for (char c : s.substr(0, 60)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  if (s.size() > 60) out += "...";
  return out;
}

// Splits on whitespace (and on `extra` separators).
inline std::vector<std::string_view> tokens(std::string_view s, std::string_view extra = {}) {
  std::vector<std::string_view> out;
  const auto is_sep = [&](char c) {
    return std::isspace(static_cast<unsigned char>(c)) != 0 ||
           extra.find(c) != std::string_view::npos;
  };
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_sep(s[i])) ++i;
    const std::size_t start = i;
    while (i < s.size() && !is_sep(s[i])) ++i;
    if (i > start) out.push_back(s.substr(start, i - start));
  }
  return out;
}

inline std::optional<double> to_double(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return value;
}

inline std::optional<std::int64_t> to_int(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return value;
}

// Exactly `count` numbers, all finite; nullopt otherwise.
inline std::optional<std::vector<double>> finite_numbers(std::string_view s, std::size_t count,
                                                         std::string_view extra = {}) {
  const auto parts = tokens(s, extra);
  if (parts.size() != count) return std::nullopt;
  std::vector<double> values;
  for (auto part : parts) {
    const auto v = to_double(part);
    if (!v || !std::isfinite(*v)) return std::nullopt;
    values.push_back(*v);
  }
  return values;
}

// Exactly `count` integers; nullopt otherwise.
inline std::optional<std::vector<std::int64_t>> integers(std::string_view s, std::size_t count) {
  const auto parts = tokens(s);
  if (parts.size() != count) return std::nullopt;
  std::vector<std::int64_t> values;
  for (auto part : parts) {
    const auto v = to_int(part);
    if (!v) return std::nullopt;
    values.push_back(*v);
  }
  return values;
}

// `name` relative to the directory holding `header_path` (absolute names stay as they are).
inline std::string beside(const std::string& header_path, std::string_view name) {
  const std::filesystem::path p{std::string(name)};
  if (p.is_absolute()) return p.string();
  return (std::filesystem::path(header_path).parent_path() / p).string();
}

// The key-value fields of a parsed text header, with lookups that fail with a one-line
// InputError naming the file. A missing required key reads missing_prefix + key + missing_suffix.
class HeaderFields {
 public:
  HeaderFields(const std::map<std::string, std::string>& fields, const std::string& path,
               std::string missing_prefix, std::string missing_suffix)
      : fields_(fields),
        path_(path),
        missing_prefix_(std::move(missing_prefix)),
        missing_suffix_(std::move(missing_suffix)) {}

  // The value of the first of `keys` present, or nullopt.
  std::optional<std::string> find(std::initializer_list<const char*> keys) const {
    for (const char* key : keys) {
      const auto it = fields_.find(key);
      if (it != fields_.end()) return it->second;
    }
    return std::nullopt;
  }

  std::string required(const char* key) const {
    const auto value = find({key});
    if (!value) throw error(missing_prefix_ + key + missing_suffix_);
    return *value;
  }

  InputError error(const std::string& message) const { return InputError(path_ + ": " + message); }
  const std::string& path() const { return path_; }

 private:
  const std::map<std::string, std::string>& fields_;
  const std::string& path_;
  std::string missing_prefix_, missing_suffix_;
};

// The data file a detached header names must be a regular file (a device, a FIFO or a socket
// would never end or block): "no such file or directory", "a loop of symbolic links" or what it
// is instead, after the header's path.
inline void require_data_file(const HeaderFields& f, const std::string& data_path) {
  try {
    require_regular_file(data_path);
  } catch (const InputError& e) {
    throw f.error(std::string("data file ") + e.what());
  }
}

}  // namespace palp::header_text
