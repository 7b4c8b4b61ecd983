// palpd's configuration file: a TOML table whose keys are palpd's long options, turned into
// "--key=value" arguments placed before the command line's (which win). Refused: a file that is
// not a regular file, unknown keys, 'config' itself, and 'no-force-limits' (command line only).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cli/commands.hpp"

namespace palp::cli {

// `flags`: the options without a value (true/false in the file); `valued`: those with one.
Arguments config_arguments(const std::string& path, const std::vector<std::string>& flags,
                           const std::vector<std::string>& valued);

// "--config FILE" / "--config=FILE" in argv, found without parsing the rest.
std::optional<std::string> config_path(const Arguments& argv);

}  // namespace palp::cli
