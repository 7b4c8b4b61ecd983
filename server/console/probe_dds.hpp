// palp probe --dds: the DDS side of palp probe (cmd_probe_dds.cpp).
#pragma once

#include "cli/commands.hpp"
#include "cli_common/cli.hpp"

namespace palp::cli {

extern const char* const kProbeDdsHelp;
// Whether the command line asks for the DDS probe (--dds).
bool wants_dds(const Arguments& argv);
int cmd_probe_dds(const Arguments& argv);

}  // namespace palp::cli
