// Shared pieces of the palp and palpd command lines: a small option parser and value formats.
// palp's commands live in server/cli (one cmd_NAME.cpp each, registered in palp_main.cpp).
#pragma once

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "base/errors.hpp"
#include "base/volume.hpp"

namespace palp::cli {

// A command's arguments, after its name.
using Arguments = std::vector<std::string>;

// A small option parser: positional arguments, "--flag" and "--key VALUE" (or --key=VALUE).
class Args {
 public:
  Args(std::vector<std::string> argv, std::vector<std::string> flags,
       std::vector<std::string> valued)
      : flags_(std::move(flags)), valued_(std::move(valued)) {
    for (std::size_t i = 0; i < argv.size(); ++i) {
      std::string arg = argv[i];
      if (arg == "-h") arg = "--help";
      if (arg == "-q") arg = "--quiet";
      if (arg.rfind("--", 0) != 0 || arg == "--") {
        positional_.push_back(arg);
        continue;
      }
      std::string key = arg.substr(2), value;
      const auto eq = key.find('=');
      const bool inline_value = eq != std::string::npos;
      if (inline_value) {
        value = key.substr(eq + 1);
        key = key.substr(0, eq);
      }
      if (contains(flags_, key) && !inline_value) {
        options_.insert_or_assign(key, std::string());  // a flag: present, no value
      } else if (contains(valued_, key)) {
        if (!inline_value) {
          if (i + 1 >= argv.size()) throw UsageError("option --" + key + " needs a value");
          value = argv[++i];
        }
        options_[key] = value;
      } else {
        throw UsageError("unknown option --" + key);
      }
    }
  }
  bool has(const std::string& key) const { return options_.count(key) != 0; }
  std::optional<std::string> get(const std::string& key) const {
    const auto it = options_.find(key);
    if (it == options_.end()) return std::nullopt;
    return it->second;
  }
  const std::vector<std::string>& positional() const { return positional_; }

  double number(const std::string& key, double fallback) const {
    const auto text = get(key);
    if (!text) return fallback;
    double value = 0;
    const auto [end, ec] = std::from_chars(text->data(), text->data() + text->size(), value);
    if (ec != std::errc() || end != text->data() + text->size() || !std::isfinite(value)) {
      throw UsageError("--" + key + " needs a number, got '" + *text + "'");
    }
    return value;
  }

 private:
  static bool contains(const std::vector<std::string>& list, const std::string& key) {
    return std::find(list.begin(), list.end(), key) != list.end();
  }
  std::vector<std::string> flags_, valued_;
  std::map<std::string, std::string> options_;
  std::vector<std::string> positional_;
};

// Parses "AxBxC" into three numbers.
template <class T>
inline std::array<T, 3> parse_triple(const std::string& text, const std::string& option) {
  std::array<T, 3> out{};
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int a = 0; a < 3; ++a) {
    const auto [next, ec] = std::from_chars(p, end, out[a]);
    if (ec != std::errc() || next == p) {
      throw UsageError("--" + option + " needs NXxNYxNZ, got '" + text + "'");
    }
    p = next;
    if (a < 2) {
      if (p == end || (*p != 'x' && *p != 'X')) {
        throw UsageError("--" + option + " needs NXxNYxNZ, got '" + text + "'");
      }
      ++p;
    }
  }
  if (p != end) throw UsageError("--" + option + " needs NXxNYxNZ, got '" + text + "'");
  return out;
}

inline std::string format_triple(const Vec3& v) {
  char text[96];
  std::snprintf(text, sizeof text, "%g x %g x %g", v[0], v[1], v[2]);
  return text;
}

}  // namespace palp::cli
