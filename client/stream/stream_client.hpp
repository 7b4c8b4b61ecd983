// palpview's network layer: one thread that connects to palpd, says Hello, receives the scene,
// the render volume and the haptic frames, and reconnects when the server goes away. The render
// thread reads the newest state with latest(); nothing it calls waits on the network.
//
// Data flow: socket -> frame decoder (palp::net) -> palp.v1 message -> plain structs below (no
// protobuf types leave client/stream/'s .cpp files and internal headers) -> one mutex-guarded
// "latest" state -> latest() copies it. The other way: send_pose / set_* -> a bounded send queue
// (the newest pose replaces an unsent one) -> the network thread writes it.
//
// Figures in LinkStats:
//   latency_ms  frame age on arrival: (arrival + clock offset) - the frame's server_time_ns (the
//               tick's deadline), median over the last second. The offset between the server's
//               clock and this one comes from Ping/Pong: of the last 32 round trips, the one with
//               the smallest round-trip time gives offset = server_time - (sent + received) / 2,
//               so it holds across hosts (error at most half that round trip), not only on
//               loopback. -1 until the first Pong.
//   delivered   from the server's Stats: client_frames_sent / (sent + dropped) over the interval
//               since the previous Stats (the frames the server queued for this client and had to
//               drop because the client or the network was too slow). Not from seq gaps: with a
//               frame rate below the tick rate, gaps are by design. -1 until the first Stats.
//
// Link states, so a stalled or dropped stream shows on screen instead of freezing silently:
//   Connecting    -> the first TCP connect and Hello in progress
//   Loading       -> Welcome and SceneInfo received, render volume chunks arriving
//   Live          -> frames arriving
//   Stalled       -> connected, but no frame for `stall_s` (Live again when frames return)
//   Reconnecting  -> the connection failed, closed or went silent for `silence_timeout_s`;
//                    retrying with exponential backoff until the next Welcome
//   Refused       -> the server refused this client with a fatal Error that retrying cannot fix
//                    (version mismatch, wrong token, controller busy, a Hello it rejects): no retry
// LinkStats::message says why (the last error, refusal, stall or reconnect reason).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "base/device_state.hpp"
#include "base/vec.hpp"
#include "model/force_model.hpp"

namespace palp::view {

enum class LinkState { Connecting, Loading, Live, Stalled, Reconnecting, Refused };
// Inline: the HUD (client/render), which does not link this library, prints it too.
constexpr const char* to_string(LinkState state) {
  switch (state) {
    case LinkState::Connecting:
      return "connecting";
    case LinkState::Loading:
      return "loading";
    case LinkState::Live:
      return "live";
    case LinkState::Stalled:
      return "stalled";
    case LinkState::Reconnecting:
      return "reconnecting";
    case LinkState::Refused:
      break;
  }
  return "refused";
}

struct StreamOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 7400;  // palpd's default
  bool controller = false;    // CONTROLLER role (sends poses and commands)
  std::string token;          // the server's controller token, when it has one
  // palp.v1 over TLS (palpd --tls-cert): the CA to check the server with (and its host name), or
  // the server certificate's SHA-256 fingerprint; this client's certificate for a palpd that
  // asks controllers for one. Neither tls_ca nor tls_pin: plain text (then no tls_cert/tls_key,
  // and a token only to loopback: tls/client_policy.hpp).
  std::string tls_ca, tls_pin, tls_cert, tls_key;
  std::string client_name = "palpview";
  double frame_rate_hz = 120.0;  // HapticFrames per second to ask for (0: every tick)
  // Render volume: at most this many voxels per axis (0: ask for no render volume).
  std::uint32_t volume_max_dim = 256;
  bool volume_hu = true;       // the CT's HU and body mask (Hello.volume_hu)
  bool volume_bone = true;     // d_bone (false: Hello.volume_skip_bone)
  bool volume_deflate = true;  // zlib on the wire (Hello.volume_deflate)
  bool volume_crop = true;     // the body's bounding box only, with hu (Hello.volume_crop)
  bool volume_labels = true;   // the structures' labels (Hello.volume_labels)
  bool want_contacts = true;
  double stall_s = 0.5;          // no frame for this long: Stalled
  double reconnect_min_s = 0.2;  // first retry delay; doubles up to reconnect_max_s
  double reconnect_max_s = 2.0;
  double silence_timeout_s = 10.0;  // nothing at all from the server for this long (connecting or
                                    // connected): drop the connection and reconnect (0: never)
  double force_history_s = 10.0;    // how much force history latest() keeps
  std::size_t force_history_max_samples = 4096;  // thinned to this many (fast servers)
  std::size_t max_queued_commands = 64;          // commands beyond this are refused locally
  // Over DDS instead of palp.v1 (palpd --dds; docs/dds.md): an observer of rig `dds_rig` on
  // domain `dds_domain` (host, port, TLS and the controller role are not used).
  bool dds = false;
  std::uint32_t dds_domain = 0;
  std::string dds_rig = "palp";
};

struct SceneDescription {
  std::string source;
  std::array<std::int64_t, 3> dims{};  // the scene's grid
  std::array<double, 3> spacing{};     // mm
  std::string tool;                    // finger:N, twofinger:N, probe:NXxNY
  std::vector<Vec3d> tool_points;      // contact points in the tool frame, mm
  double c = 0, k = 0, bone_fmax = 0;
  std::string device, device_profile;
  double tick_rate_hz = 0;
  bool device_renders_force = true;  // false: nobody feels the force, show it on screen
  std::array<double, 3> origin{};    // file origin, LPS (metadata only)
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major (metadata only)
  bool bone_enabled = true;
  std::map<std::string, std::string> metadata;  // palpd: prep_dir, scheme, storage
  std::string server_name;                      // from Welcome
  // The structures beyond skin and bone (SceneInfo.structures; none from an older palpd), in
  // label order: RenderVolume::labels holds their labels.
  struct Structure {
    std::uint8_t label = 0;  // 1..64
    std::string name;        // "vessel", "artery", "liver", ...
    std::string kind;        // "vessel", "artery", "organ" (another kind is drawn as an organ)
  };
  std::vector<Structure> structures;
  double pulse_bpm = 0;  // Parameters.pulse_bpm when the SceneInfo was sent (frames: now)
  // Where the device sits on the patient (palpd --home ...); unset for scene-frame devices.
  struct Placement {
    std::array<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};  // row-major, device -> scene
    double scale = 1;
    Vec3d home{};               // scene mm, at start (LinkStats::registration_home: now)
    Vec3d workspace_half_mm{};  // the device's box, +- about its origin
    std::string home_site, axes;
    Vec3d home_skin{};
  };
  std::optional<Placement> placement;
};

// The render volume the server sent, complete (all chunks). Voxel (i, j, k) sits at
// (i, j, k) * spacing in the scene frame (mm); values float32, i fastest.
struct RenderVolume {
  std::array<std::int64_t, 3> dims{};
  std::array<double, 3> spacing{};  // mm between samples (scene spacing * step)
  // Where voxel (0, 0, 0) lies, scene frame mm: (0, 0, 0) unless palpd cropped the volume to the
  // body (Hello.volume_crop); voxel (i, j, k) lies at origin + (i, j, k) * spacing.
  std::array<double, 3> origin{};
  std::uint32_t step = 1;
  std::vector<float> d_surf;       // mm, positive inside the body
  std::vector<float> d_bone;       // mm, positive inside bone; empty when the scene has none
  std::vector<std::int16_t> hu;    // the CT's HU; empty unless asked for and the scene has it
  std::vector<std::uint8_t> body;  // 0/1 body mask (with hu)
  // The structure of each voxel (SceneDescription::structures' labels, 0: none); empty unless
  // asked for and the scene has structures.
  std::vector<std::uint8_t> labels;
};

struct ContactState {
  Vec3d x{}, s{}, p{}, f{};  // position, surface point, proxy (mm, scene frame), force (N)
  bool in_contact = false;
};

// base/device_state.hpp; Unknown: the server did not say (older palpd, or not yet).
using DeviceState = palp::DeviceState;
using palp::to_string;

struct FrameState {
  bool valid = false;  // false until the first frame of this connection
  std::uint64_t seq = 0;
  std::int64_t server_time_ns = 0;
  Pose pose{};
  Vec3d force{}, torque{}, u{};
  std::uint32_t n_contact = 0, contact_points = 0;
  std::vector<ContactState> contacts;
  std::uint32_t tick_status = 0, safety_status = 0, fault = 0;
  DeviceState device_state = DeviceState::Unknown;
  // The structure layers (HapticFrame 15..18): the arterial pressure 0 (diastole) .. 1
  // (systole), |the pulse's| and |the organ borders'| force (N); the heart rate in force, unset
  // from a palpd that does not say.
  double pulse_wave = 0, pulse_force = 0, organ_force = 0;
  std::optional<double> pulse_bpm;
};

struct ForceSample {
  double t_s = 0;  // seconds, server clock, relative to the first frame of the connection
  Vec3d force{};
  std::int64_t server_time_ns = 0;  // the tick's deadline, server clock
};

struct LinkStats {
  LinkState state = LinkState::Connecting;
  std::string message;            // why: the last error, refusal or reconnect reason
  std::uint64_t connections = 0;  // successful connections so far (> 1: it reconnected)
  double frames_per_s = 0;        // frames received per second, over the last second
  std::uint64_t frames = 0;       // frames received on this connection
  double delivered = -1;   // sent / (sent + dropped) for this client, from Stats (-1: no Stats yet)
  double latency_ms = -1;  // frame age on arrival, median over the last second (-1: n/a)
  double rtt_ms = -1;      // smallest Ping round trip of the last 32 (-1: none yet)
  double clock_offset_ms = 0;      // server clock - this clock, from that round trip
  double since_last_frame_s = 0;   // at the latest() call (0 before the first frame)
  double server_tick_rate_hz = 0;  // from the server's Stats
  std::uint64_t server_overruns = 0, server_faults = 0;
  bool server_paused = false, server_recording = false;
  DeviceState device_state = DeviceState::Unknown;  // from Stats
  std::optional<Vec3d> registration_home;           // from Stats: the device's home now
  std::uint64_t recentres = 0;                      // from Stats
  std::string device_message;                       // from Stats: the device's last event
  std::uint64_t server_errors = 0;    // non-fatal Errors the server sent (text in `message`)
  double volume_progress = 0;         // 0..1 while Loading
  std::uint64_t last_request_id = 0;  // the last CommandResult: request, ok, message
  bool last_result_ok = false;
  std::string last_result_message;
};

// The training task as palpd tells this client (TaskStatus; none from a palpd without tasks).
// The trainee's controller gets no score and show_landmarks false while a task runs.
struct TaskInfo {
  bool running = false;
  std::string task;  // "ptcd right 9/10"; empty before any task
  std::uint32_t trial = 0, marks = 0;
  bool show_landmarks = false;
  std::optional<double> last_distance_mm;  // the last mark's score (observers)
  bool last_in_target = false;
  std::string last_where;
};
// A landmark to draw (LandmarkSet), scene frame mm; at most kMaxLandmarks (a larger set is
// dropped).
struct LandmarkPoint {
  std::string name, kind;
  Vec3d point{};
};
inline constexpr int kMaxLandmarks = 1024;

struct LatestState {
  std::uint64_t connection = 0;  // changes on every (re)connection: rebuild the scene
  std::shared_ptr<const SceneDescription> scene;  // null until SceneInfo
  std::shared_ptr<const RenderVolume> volume;     // null until the last chunk
  FrameState frame;
  LinkStats link;
  std::vector<ForceSample> force_history;  // oldest first, force_history_s long
  std::optional<TaskInfo> task;
  std::shared_ptr<const std::vector<LandmarkPoint>> landmarks;  // null: none received
};

class StreamClient {
 public:
  explicit StreamClient(StreamOptions options);
  ~StreamClient();  // stop()
  StreamClient(const StreamClient&) = delete;
  StreamClient& operator=(const StreamClient&) = delete;

  void start();  // starts the network thread
  void stop();   // closes the connection and joins; idempotent

  // A copy of the newest state (render thread; never waits on the network). Thread-safe.
  LatestState latest() const;

  // CONTROLLER only (ignored otherwise: commands return 0): queued and sent by the network
  // thread. Poses are dropped while not Live and when not finite; an unsent pose is replaced by
  // the next. Commands return their request id (> 0); the answer lands in LinkStats. A command
  // that cannot be sent (not connected, queue full, unusable value) gets a failed result at once.
  void send_pose(const Pose& pose);
  std::uint64_t set_tool(const std::string& tool);
  std::uint64_t set_parameter(const std::string& name, double value);
  std::uint64_t set_paused(bool paused);
  // The arteries' heart rate (SetParameter pulse_bpm, 0..240; palpd applies it between ticks).
  std::uint64_t set_pulse_bpm(double bpm) { return set_parameter("pulse_bpm", bpm); }
  // Re-centre a registered device (palpd moves its home at the next tick out of contact).
  std::uint64_t recentre();
  // Start a recording named `name` in palpd's --record-dir (refused when it exists), or stop it.
  std::uint64_t start_recording(const std::string& name);
  std::uint64_t stop_recording();
  // The training task: mark the spot (TaskMark; palpd scores it).
  std::uint64_t task_mark();

  const StreamOptions& options() const { return options_; }

 private:
  struct Impl;
  StreamOptions options_;
  std::unique_ptr<Impl> impl_;
};

// "" when `options` may connect; otherwise why not, said before anything is sent: a token for
// another machine without TLS (tls/client_policy.hpp; the network thread checks again at every
// connect and goes Refused). Resolves the host, blocking; a host that does not resolve is left to
// the network thread. palpview asks before it opens its window.
std::string connect_refusal(const StreamOptions& options);

}  // namespace palp::view
