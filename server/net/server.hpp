// The palpd network server (Asio, one io thread): streams the haptic loop's snapshots to many
// clients over TCP in palp.v1 (proto/palp.proto), and hands controller commands to palpd.
//
// Per client: Hello first (version 1, role, token for CONTROLLER when one is configured), then
// Welcome, SceneInfo and - when asked for - the render volume in chunks, and only then
// HapticFrames (late joiners get the scene before frames). Frames go into a bounded per-client
// queue; when it is full the oldest frame is dropped (counted), so a slow client gets the newest
// frames and never holds anyone up. Everything a client has queued (frames, errors, pongs,
// command results, scene and stats messages) is also bounded in bytes (max_queue_bytes, each
// message counted with kQueueEntryOverhead): stale frames go first, and a client whose other
// messages still exceed the bound (one that floods Pings or Commands and never reads) is
// dropped; its queues are freed a slice at a time between polls, never all at once on the io
// thread. One write is in flight per client, gathering everything queued. Stats about once a
// second. Sockets use TCP_NODELAY.
//
// Protocol violations get an Error with a reason and never take the server down:
//   first message not a Hello, version mismatch, bad role, wrong token, second controller,
//   too many clients, undecodable envelope before Hello, oversize frame or bad length prefix
//     -> Error (fatal) and the connection is closed after it is sent;
//   undecodable or invalid message after Hello, Command / DevicePose from an observer, second
//   Hello -> Error (not fatal).
// Timeouts: no Hello within hello_timeout_s, nothing received for idle_timeout_s (clients Ping),
// a write that makes no progress for write_timeout_s: the connection is closed.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "base/volume.hpp"
#include "loop/haptic_loop.hpp"
#include "model/field_sampler.hpp"
#include "net/control_target.hpp"
#include "net/frame_pump.hpp"
#include "scene/structure_labels.hpp"

namespace palp::tls {
class ServerContext;
}

namespace palp::net {

struct ServerConfig {
  std::string bind = "127.0.0.1";
  std::uint16_t port = 7400;     // 0: any free port (see Server::port())
  std::size_t max_clients = 16;  // admitted observers; the controller's slot is always kept free
  // Connections that have not said Hello yet: a budget of their own, so silent sockets cannot
  // fill max_clients, and a smaller one per remote address (one host cannot take them all).
  std::size_t max_pending = 64;
  std::size_t max_pending_per_address = 4;
  std::string token;                        // non-empty: CONTROLLER must present it
  std::size_t max_frame_bytes = 64 * 1024;  // client -> server
  std::size_t queue_frames = 256;           // HapticFrames queued per client before dropping
  std::size_t max_queue_bytes = 4 << 20;    // all messages queued per client (client_queue.hpp)
  double hello_timeout_s = 5.0;
  double idle_timeout_s = 30.0;  // 0: off
  double write_timeout_s = 5.0;  // 0: off
  double stats_interval_s = 1.0;
  NetWake net_wake = NetWake::Event;  // how the io thread learns of new frames (frame_pump.hpp)
  double poll_interval_s = 0.0005;    // NetWake::Poll: how often it drains the loop's ring
  int cpu = -1;                       // >= 0: the io thread is pinned to this CPU
  std::size_t volume_chunk_bytes = 1 << 20;  // per map, per chunk
  int send_buffer_bytes = 0;                 // SO_SNDBUF of client sockets (0: system default)
  std::string server_name = "palpd";
  bool log_clients = true;  // clients joining, leaving and refused, on stderr (rate-bounded)
  // Set: palp.v1 over TLS only (plain text refused); with a client CA, controllers need a
  // certificate (net/tls_accept.hpp). Unset: plain text, the token only from loopback.
  std::shared_ptr<tls::ServerContext> tls;
};

// Whether palpd could listen on bind:port (port 0 always can), checked before the scene is
// loaded so a port in use is told at once: ResourceError saying what to change, UsageError for
// a bind that is not an address.
void check_listen_address(const std::string& bind, std::uint16_t port);

// What SceneInfo describes besides the model (which comes from the loop).
struct SceneDescription {
  std::string source;
  Grid grid;
  std::map<std::string, std::string> metadata;
  std::string device;
  std::string device_profile;
  std::shared_ptr<const FieldSampler> fields;  // sampled for the render volume
  std::shared_ptr<const CtVolume> ct;          // the CT's HU on the grid (may be null)
  std::shared_ptr<const Mask> body;            // the body mask on the grid (with ct)
  // The prep directory's structures (vessels, artery, organs) as labels on a grid `grid` refines
  // (null or empty: none): SceneInfo.structures and, when asked, VolumeChunk.labels.
  std::shared_ptr<const StructureLabels> structures;
  // The device's registration, for devices placed on the patient (unset: scene-frame devices).
  struct Placement {
    Registration registration;
    Vec3d workspace_half_mm{};
    std::string home_site, axes;
    Vec3d home_skin{};
  };
  std::optional<Placement> placement;
};

struct ServerCounters {
  std::uint64_t accepted = 0;
  std::uint64_t rejected = 0;         // closed with a fatal Error
  std::uint64_t protocol_errors = 0;  // Errors sent
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_dropped = 0;  // stale frames dropped from client queues
  std::uint64_t timeouts = 0;
  std::uint64_t overflows = 0;    // clients dropped for exceeding max_queue_bytes
  std::uint64_t net_wakeups = 0;  // times the io thread took frames from the loop (frame_pump)
};

class Server {
 public:
  // Binds and listens (ResourceError when the address cannot be used); nothing runs until start().
  Server(ServerConfig config, SceneDescription scene, rt::HapticLoop& loop, ControlTarget* control);
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  std::uint16_t port() const;
  void start();  // the io thread
  void stop();   // closes every connection and joins; idempotent
  std::size_t client_count() const;
  ServerCounters counters() const;
  // Sends SceneInfo again to every client (after the tool or parameters changed).
  void scene_changed();
  // Called on the io thread with every snapshot it drains (the OpenIGTLink and DDS bridges read
  // the same snapshots as palp.v1); added before start(), in order, never blocks. `rate_hz`: the
  // rate at which the tap keeps snapshots (0: every one), so the loop wakes the io thread for
  // the ticks it keeps and not for every one (frame_schedule.hpp).
  void add_snapshot_tap(std::function<void(const rt::Snapshot&)> tap, double rate_hz = 0.0);

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace palp::net
