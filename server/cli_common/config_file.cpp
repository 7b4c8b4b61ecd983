// palpd's configuration file: see config_file.hpp.
#include "cli_common/config_file.hpp"

#include <toml++/toml.h>

#include <algorithm>

#include "base/errors.hpp"
#include "cli_common/model_setup.hpp"
#include "io/gzip.hpp"
#include "scene/trajectory.hpp"

namespace palp::cli {

// The TOML file as "--key=value" arguments (placed before the command line's, which win).
Arguments config_arguments(const std::string& path, const std::vector<std::string>& flags,
                           const std::vector<std::string>& valued,
                           std::map<std::string, int>* lines) {
  toml::table table;
  try {
    require_regular_file(path);  // a FIFO would block palpd's start forever
  } catch (const InputError& e) {
    throw UsageError(std::string("--config: ") + e.what());
  }
  try {
    table = toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw UsageError(path + ": " + std::string(e.description()) + " (line " +
                     std::to_string(e.source().begin.line) + ")");
  }
  Arguments out;
  for (const auto& [key_node, node] : table) {
    const std::string key(key_node.str());
    const std::string at =
        path + " line " + std::to_string(node.source().begin.line) + ", key '" + key + "'";
    if (lines) (*lines)[key] = static_cast<int>(node.source().begin.line);
    const auto scalar = [&](const toml::node& n) -> std::string {
      if (const auto s = n.value<std::string>()) return *s;
      if (const auto i = n.value<std::int64_t>()) return std::to_string(*i);
      if (const auto d = n.value<double>()) return number_text(*d);
      throw UsageError(at + ": must be a string or a number");
    };
    if (key == "config") throw UsageError(at + ": 'config' cannot be set in a config file");
    if (key == "no-force-limits")
      throw UsageError(at + ": cannot be set in a config file (command line only)");
    if (key == "param") {
      if (const toml::array* a = node.as_array()) {
        for (const toml::node& item : *a) out.push_back("--param=" + scalar(item));
      } else if (const toml::table* t = node.as_table()) {
        for (const auto& [name, value] : *t)
          out.push_back("--param=" + std::string(name.str()) + "=" + scalar(value));
      } else {
        throw UsageError(at + ": must be an array of \"NAME=VALUE\" or a table");
      }
      continue;
    }
    if (std::find(flags.begin(), flags.end(), key) != flags.end() || key == "realtime") {
      const auto b = node.value<bool>();
      if (!b) throw UsageError(at + ": must be true or false");
      if (key == "realtime") {
        if (!*b) out.push_back("--no-realtime");
      } else if (*b) {
        out.push_back("--" + key);
      }
      continue;
    }
    if (std::find(valued.begin(), valued.end(), key) == valued.end() &&
        std::find(kSceneOptions.begin(), kSceneOptions.end(), key) == kSceneOptions.end())
      throw UsageError(at +
                       ": unknown key (palpd --help lists the options; a key is an option's "
                       "name without its dashes)");
    out.push_back("--" + key + "=" + scalar(node));
  }
  return out;
}

std::string config_error(const std::string& message, const std::string& path,
                         const std::map<std::string, int>& lines, const Arguments& command_line) {
  if (message.rfind("--", 0) != 0) return message;
  const std::size_t end = message.find_first_of(" =", 2);
  const std::string key = message.substr(2, end == std::string::npos ? end : end - 2);
  const auto it = lines.find(key);
  if (it == lines.end()) return message;
  for (const std::string& arg : command_line)
    if (arg == "--" + key || arg.rfind("--" + key + "=", 0) == 0) return message;
  return path + " line " + std::to_string(it->second) + ", key '" + key + "': " + message;
}

std::optional<std::string> config_value(const std::string& path, const std::string& key) {
  try {
    require_regular_file(path);
    const toml::table table = toml::parse_file(path);
    const toml::node* node = table.get(key);
    if (!node) return std::nullopt;
    if (const auto s = node->value<std::string>()) return *s;
    if (const auto d = node->value<double>()) return number_text(*d);
    throw UsageError(path + ": '" + key + "' must be a string or a number");
  } catch (const InputError& e) {
    throw UsageError(std::string("--config: ") + e.what());
  } catch (const toml::parse_error& e) {
    throw UsageError(path + ": " + std::string(e.description()) + " (line " +
                     std::to_string(e.source().begin.line) + ")");
  }
}

// Finds "--config FILE" / "--config=FILE" in argv without parsing the rest.
std::optional<std::string> config_path(const Arguments& argv) {
  for (std::size_t i = 0; i < argv.size(); ++i) {
    if (argv[i] == "--config" && i + 1 < argv.size()) return argv[i + 1];
    if (argv[i].rfind("--config=", 0) == 0) return argv[i].substr(9);
  }
  return std::nullopt;
}

Arguments with_model_config(const Arguments& argv) {
  const bool help = std::find(argv.begin(), argv.end(), "--help") != argv.end() ||
                    std::find(argv.begin(), argv.end(), "-h") != argv.end();
  const auto config = help ? std::nullopt : config_path(argv);
  if (!config) return argv;
  Arguments out;
  // `rate` is the loop rate the file was tuned for: an offline run follows its own times.
  for (std::string& a : config_arguments(*config, {}, kModelConfigKeys))
    if (a.rfind("--rate=", 0) != 0) out.push_back(std::move(a));
  out.insert(out.end(), argv.begin(), argv.end());
  return out;
}

}  // namespace palp::cli
