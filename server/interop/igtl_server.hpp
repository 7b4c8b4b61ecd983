// OpenIGTLink beside palp.v1 (3D Slicer's OpenIGTLinkIF, PLUS, any IGT receiver): a TCP server of
// its own, on a thread of its own, that sends at a fixed rate
//   TRANSFORM <tool_name>  (default PalpTool)   tool frame -> the CT's patient frame, RAS, mm
//   TRANSFORM <force_name> (default PalpForce)  translation = device force in RAS axes, N
//   TRANSFORM <u_name>     (default PalpU)      translation = displacement u in RAS axes, mm
// (igtl_frame.hpp: where RAS comes from; docs/slicer.md: why TRANSFORM for the vectors).
//
// It never touches the real-time loop: the palp.v1 network thread hands it every snapshot it
// drains (offer(), which keeps one sample per 1/rate of loop time in a triple buffer and never
// waits); this thread packs the newest sample with the OpenIGTLink library and queues it to each
// client. Each client is isolated: a bounded queue of samples (the oldest dropped when full,
// counted), one write in flight, a client whose socket accepts nothing for write_timeout_s is
// closed, bytes it sends are read into a fixed buffer and discarded, and at most max_clients are
// served (the next is closed at once, counted).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "base/volume.hpp"
#include "rt/snapshot.hpp"

namespace palp::interop {

struct IgtlConfig {
  std::string bind = "127.0.0.1";
  std::uint16_t port = 18944;  // Slicer's default; 0: any free port (see IgtlServer::port())
  double rate_hz = 60.0;       // samples per second of loop time, at most the loop's rate
  std::string tool_name = "PalpTool";
  std::string force_name = "PalpForce";
  std::string u_name = "PalpU";
  std::size_t max_clients = 8;
  std::size_t queue_samples = 64;  // per client; the oldest is dropped beyond it
  double write_timeout_s = 5.0;    // 0: never
  int send_buffer_bytes = 0;       // SO_SNDBUF of client sockets (0: the system's default)
};

struct IgtlCounters {
  std::uint64_t accepted = 0;
  std::uint64_t refused = 0;          // over max_clients
  std::uint64_t samples_offered = 0;  // kept by offer() (one per 1/rate of loop time)
  std::uint64_t samples_sent = 0;     // queued to a client (per client)
  std::uint64_t samples_dropped = 0;  // dropped from a full client queue
  std::uint64_t timeouts = 0;         // clients closed for a stalled write
};

class IgtlServer {
 public:
  // Binds and listens (ResourceError when it cannot); `grid` places scene poses in the patient.
  IgtlServer(IgtlConfig config, const Grid& grid);
  ~IgtlServer();  // stop()
  IgtlServer(const IgtlServer&) = delete;
  IgtlServer& operator=(const IgtlServer&) = delete;

  std::uint16_t port() const;
  const IgtlConfig& config() const;
  void start();
  void stop();  // idempotent
  // One thread only (the palp.v1 io thread): never waits, never allocates.
  void offer(const rt::Snapshot& snapshot) noexcept;
  std::size_t client_count() const;
  IgtlCounters counters() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palp::interop
