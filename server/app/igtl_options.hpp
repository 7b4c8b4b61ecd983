// palpd's OpenIGTLink options (--igtl-port and the rest, also config file keys), kept out of
// palpd_main.cpp: their help text, their names, and the server they ask for.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "cli_common/cli.hpp"
#include "interop/igtl_server.hpp"
#include "net/server.hpp"

namespace palp::app {

extern const char* const kIgtlOptionsHelp;
// `valued` and the OpenIGTLink options' names (palpd's valued options and config file keys).
std::vector<std::string> with_igtl_options(std::vector<std::string> valued);
// Every OpenIGTLink option's name.
const std::vector<std::string>& igtl_valued_options();

// The config asked for by `args`, or nothing without --igtl-port. UsageError for a value out of
// range; the rate is capped at the loop's (`loop_rate_hz`), with a note on stderr.
std::unique_ptr<interop::IgtlConfig> igtl_config_from(const cli::Args& args, double loop_rate_hz);

// With --igtl-port: an OpenIGTLink server (bound now, so a port in use stops palpd before its
// loop starts) fed by `server`'s snapshot tap, and its address printed unless `quiet`. The tap
// owns it: it lives as long as `server`. Nothing without --igtl-port.
std::shared_ptr<interop::IgtlServer> igtl_beside(const cli::Args& args, const Grid& grid,
                                                 double loop_rate_hz, net::Server& server,
                                                 bool quiet);

}  // namespace palp::app
