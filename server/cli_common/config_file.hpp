// palpd's configuration file: a TOML table whose keys are palpd's long options, turned into
// "--key=value" arguments placed before the command line's (which win). Refused: a file that is
// not a regular file, unknown keys, 'config' itself, and 'no-force-limits' (command line only).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "cli_common/cli.hpp"

namespace palp::cli {

// `flags`: the options without a value (true/false in the file); `valued`: those with one.
// `lines` (when given) receives the line of each key, for errors found later in its value.
Arguments config_arguments(const std::string& path, const std::vector<std::string>& flags,
                           const std::vector<std::string>& valued,
                           std::map<std::string, int>* lines = nullptr);

// A usage error in an option's value that came from the config file, told as the file's: "FILE
// line N, key 'rate': --rate ..." when `message` starts with "--KEY" for a KEY set in the file
// and not on the command line (`command_line`); otherwise the message unchanged.
std::string config_error(const std::string& message, const std::string& path,
                         const std::map<std::string, int>& lines, const Arguments& command_line);

// The string (or number, as text) under `key` in a config file, without checking the other keys
// (palp ctl reads palpd's token this way). UsageError naming the file for an unreadable file.
std::optional<std::string> config_value(const std::string& path, const std::string& key);

// "--config FILE" / "--config=FILE" in argv, found without parsing the rest.
std::optional<std::string> config_path(const Arguments& argv);

// The model keys a command that runs the force model offline (palp run, palp bench) reads from
// `--config FILE`: scene, tool, model, scheme, storage, param (and rate, read and not used), as a
// `palp tune --out` file or a palpd config has them.
inline const std::vector<std::string> kModelConfigKeys = {"scene",   "tool",  "model", "scheme",
                                                          "storage", "param", "rate"};

// `argv` with FILE's model keys (kModelConfigKeys but rate) as "--key=value" before its own
// options, which win; `argv` unchanged without --config, or with --help / -h.
Arguments with_model_config(const Arguments& argv);

}  // namespace palp::cli
