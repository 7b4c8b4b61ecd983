// palpd's options for the timing of the loop and of the network thread: how the loop waits for
// its deadlines (--wake, --spin-us), which CPUs the two threads run on (--rt-cpu, --net-cpu) and
// how the network thread learns of new frames (--net-wake). docs/operations.md says how to set a
// lab PC up for them.
#pragma once

#include <string>
#include <vector>

#include "cli_common/cli.hpp"
#include "loop/haptic_loop.hpp"
#include "net/server.hpp"

namespace palp::app {

inline constexpr const char* kRtOptionsHelp =
    R"(Timing of the loop and of the network thread (docs/operations.md, "A PC for high rates"):
  --wake MODE             how the loop waits for each deadline: hybrid (default: sleep until
                          shortly before it, then spin on the clock; the spin window follows
                          the measured wake-up latency) or sleep (clock_nanosleep to the
                          deadline, as before)
  --spin-us US            hybrid: spin this long before each deadline instead of the measured
                          window (0 = measured, the default; at most the period)
  --rt-cpu N              pin the loop thread to CPU N and keep palpd's other threads off it
                          (pair with isolcpus=N nohz_full=N on the kernel command line)
  --net-cpu N             pin the network thread to CPU N (not --rt-cpu's)
  --net-wake MODE         how the network thread learns of new frames: event (default: the
                          loop signals an eventfd when the network thread waits and a client
                          is due a frame at the rate it asked for), event-every
                          (the loop signals after every tick) or poll (every --poll-us)
)";

inline const std::vector<std::string> kRtValued = {"wake", "spin-us", "rt-cpu", "net-cpu",
                                                   "net-wake"};

// `valued` with the options above.
std::vector<std::string> with_rt_options(std::vector<std::string> valued);

// Reads the options above into the two configurations (UsageError for a bad value, a CPU this
// process may not use, or both threads on one CPU). With --rt-cpu the calling thread is taken
// off that CPU, so every thread palpd starts afterwards (device, network, recorder) inherits it.
void apply_rt_options(const cli::Args& args, rt::LoopConfig& loop, net::ServerConfig& server);

}  // namespace palp::app
