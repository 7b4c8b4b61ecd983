// palp probe --check-rate HZ: a local timing test of this machine with the loop's own wake-up
// and deadline logic (loop/wake.hpp), a stand-in tick of --work-us busy time followed by palpd's
// hand-off to the network thread (a snapshot into a ring, the eventfd written when a stand-in
// client is due a frame: rt/wake_signal.hpp, net/frame_pump.hpp, a network thread draining it),
// and a verdict.
#pragma once

#include "cli/commands.hpp"
#include "cli_common/cli.hpp"

namespace palp::cli {

inline constexpr const char* kCheckRateHelp =
    R"(  --check-rate HZ         no server: time a loop at HZ on this machine for --duration S, the
                          way palpd's loop waits, and say whether the machine can hold that
                          rate (exit 0) or not (exit 1); with these options:
  --wake MODE             hybrid (default) or sleep, as palpd's --wake
  --spin-us US            a fixed spin window, as palpd's --spin-us (0 = measured)
  --rt-cpu N              pin the timing thread to CPU N
  --work-us US            busy time per tick standing in for the force model (default 5)
  --clients N             stand-in clients of the network thread it hands snapshots to, as
                          palpd's loop does (default 0: palpd with nobody connected)
  --client-hz HZ          the frames per second they ask for (default 0: every tick)
  --net-wake MODE         event (default), event-every or poll, as palpd's --net-wake
  --max-miss PCT          the deadline misses it may have and still hold the rate (0.1)
  --no-realtime           do not ask for SCHED_FIFO
)";

// True when `argv` asks for --check-rate.
bool wants_check_rate(const Arguments& argv);
int cmd_check_rate(const Arguments& argv);

}  // namespace palp::cli
