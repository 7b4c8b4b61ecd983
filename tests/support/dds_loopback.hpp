// DDS in tests: Cyclone on the loopback interface only, unicast discovery to localhost (multicast
// on lo is not dependable), enough participant indices for many subscribers, and a domain id of
// each test's own so parallel tests never see each other.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <string>

namespace palp::testing {

inline const char* dds_loopback_uri() {
  return "<CycloneDDS><Domain id=\"any\"><General><Interfaces><NetworkInterface name=\"lo\"/>"
         "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><Peers>"
         "<Peer address=\"localhost\"/></Peers><ParticipantIndex>auto</ParticipantIndex>"
         "<MaxAutoParticipantIndex>100</MaxAutoParticipantIndex></Discovery></Domain>"
         "</CycloneDDS>";
}

// Sets CYCLONEDDS_URI for this process and the processes it starts.
inline void use_dds_loopback() {
  setenv("CYCLONEDDS_URI", dds_loopback_uri(), 1);
}

// A domain id (1..230) that differs between test processes running at once and between calls.
inline std::uint32_t unique_dds_domain() {
  static std::uint32_t calls = 0;
  return 1 + static_cast<std::uint32_t>((getpid() * 7 + calls++ * 13) % 230);
}

}  // namespace palp::testing
