#include "app/igtl_options.hpp"

#include <cstdio>

#include "base/errors.hpp"

namespace palp::app {

const char* const kIgtlOptionsHelp =
    R"(OpenIGTLink (3D Slicer's OpenIGTLinkIF; docs/slicer.md), on --bind beside palp.v1:
  --igtl-port P           serve OpenIGTLink on port P (Slicer's default is 18944; 0 = any free
                          port, printed at start); off without it
  --igtl-rate HZ          messages per second of each stream (60; at most the loop's --rate)
  --igtl-device NAMES     TOOL[,FORCE,U]: device names of the tool pose (TRANSFORM in the CT's
                          RAS patient frame) and of the force (N) and displacement u (mm)
                          streams (TRANSFORMs whose translation is the vector in RAS axes)
                          (PalpTool,PalpForce,PalpU)
  --igtl-max-clients N    OpenIGTLink clients served at once (8; 1..64); more are closed
)";

const std::vector<std::string>& igtl_valued_options() {
  static const std::vector<std::string> names = {"igtl-port", "igtl-rate", "igtl-device",
                                                 "igtl-max-clients"};
  return names;
}

std::vector<std::string> with_igtl_options(std::vector<std::string> valued) {
  valued.insert(valued.end(), igtl_valued_options().begin(), igtl_valued_options().end());
  return valued;
}

namespace {

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 20) return false;  // the OpenIGTLink header holds 20 bytes
  for (const char ch : s)
    if (ch < 0x21 || ch > 0x7e) return false;
  return true;
}

}  // namespace

std::unique_ptr<interop::IgtlConfig> igtl_config_from(const cli::Args& args, double loop_rate_hz) {
  if (!args.has("igtl-port")) {
    for (const std::string& key : igtl_valued_options())
      if (args.has(key)) throw UsageError("--" + key + " needs --igtl-port");
    return nullptr;
  }
  auto config = std::make_unique<interop::IgtlConfig>();
  const double port = args.number("igtl-port", 0);
  if (!(port >= 0 && port <= 65535) || port != static_cast<int>(port))
    throw UsageError("--igtl-port must be an integer in 0..65535");
  config->port = static_cast<std::uint16_t>(port);
  config->bind = args.get("bind").value_or("127.0.0.1");
  config->rate_hz = args.number("igtl-rate", 60.0);
  if (!(config->rate_hz > 0.0 && config->rate_hz <= 100000.0))
    throw UsageError("--igtl-rate must be in (0, 100000] Hz");
  if (config->rate_hz > loop_rate_hz) {
    std::fprintf(stderr, "palpd: --igtl-rate %g is above the loop's %g Hz: sending at %g Hz\n",
                 config->rate_hz, loop_rate_hz, loop_rate_hz);
    config->rate_hz = loop_rate_hz;
  }
  const double max_clients = args.number("igtl-max-clients", 8);
  if (!(max_clients >= 1 && max_clients <= 64) || max_clients != static_cast<int>(max_clients))
    throw UsageError("--igtl-max-clients must be an integer in 1..64");
  config->max_clients = static_cast<std::size_t>(max_clients);
  if (const auto names = args.get("igtl-device")) {
    std::vector<std::string> parts;
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = names->find(',', start);
      parts.push_back(names->substr(start, comma - start));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    if (parts.size() != 1 && parts.size() != 3)
      throw UsageError("--igtl-device needs TOOL or TOOL,FORCE,U, got '" + *names + "'");
    for (const std::string& p : parts)
      if (!valid_name(p))
        throw UsageError("--igtl-device: '" + p +
                         "' is not a device name (1..20 printable characters, no spaces)");
    config->tool_name = parts[0];
    if (parts.size() == 3) config->force_name = parts[1], config->u_name = parts[2];
    if (config->tool_name == config->force_name || config->tool_name == config->u_name ||
        config->force_name == config->u_name)
      throw UsageError("--igtl-device: the three names must differ, got '" + *names + "'");
  }
  return config;
}

std::shared_ptr<interop::IgtlServer> igtl_beside(const cli::Args& args, const Grid& grid,
                                                 double loop_rate_hz, net::Server& server,
                                                 bool quiet) {
  const auto config = igtl_config_from(args, loop_rate_hz);
  if (!config) return nullptr;
#ifndef PALP_HAVE_OPENIGTLINK
  (void)grid, (void)server, (void)quiet;
  throw UsageError(
      "this palpd was built without OpenIGTLink: install libopenigtlink-dev "
      "(deploy/install-deps.sh) and build again to use --igtl-port");
#else
  auto igtl = std::make_shared<interop::IgtlServer>(*config, grid);
  server.add_snapshot_tap([igtl](const rt::Snapshot& s) { igtl->offer(s); }, config->rate_hz);
  igtl->start();
  if (!quiet) {
    std::printf("palpd: OpenIGTLink on %s:%u: %s, %s, %s at %g Hz (RAS patient frame)\n",
                config->bind.c_str(), static_cast<unsigned>(igtl->port()),
                config->tool_name.c_str(), config->force_name.c_str(), config->u_name.c_str(),
                config->rate_hz);
    std::fflush(stdout);
  }
  return igtl;
#endif
}

}  // namespace palp::app
