// Server::Impl, the io thread's side of the palpd network server (server.hpp), shared by the
// files that define it (private to server/net):
//   server.cpp         start and stop; accepting clients, reading their messages, Hello, commands
//   server_send.cpp    the write side: per-client queues, the one write in flight, errors, close
//   server_frames.cpp  frames from the loop, scene, volume and task delivery, housekeeping, Stats
// Everything runs on the io thread except the constructor, start(), stop() and the atomic
// counters.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "asio.hpp"
#include "net/client_log.hpp"
#include "net/client_queue.hpp"
#include "net/force_history.hpp"
#include "net/server.hpp"
#include "net/session.hpp"
#include "net/token_guard.hpp"
#include "net/volume_cache.hpp"

namespace palp::net {

class Server::Impl {
 public:
  Impl(ServerConfig config, SceneDescription scene, rt::HapticLoop& loop, ControlTarget* control);
  ~Impl() { stop(); }

  void start();
  void stop();

  void scene_changed() {
    asio::post(io_, [this] { scene_dirty_ = true; });
  }
  struct Tap {
    std::function<void(const rt::Snapshot&)> offer;
    FrameSchedule frames;
  };
  std::vector<Tap> taps_;  // added before start()

  std::uint16_t port() const { return port_; }
  std::size_t client_count() const { return client_count_.load(); }
  ServerCounters counters() const {
    return {accepted_.load(),       rejected_.load(), protocol_errors_.load(), frames_sent_.load(),
            frames_dropped_.load(), timeouts_.load(), overflows_.load(),       pump_.wakeups()};
  }

  using Session = ServerSession;
  using SessionPtr = std::shared_ptr<Session>;

 private:
  // ---- server.cpp: accepting and reading clients
  void accept();
  void on_accept(const SessionPtr& s);
  void read(const SessionPtr& s);
  void handle(const SessionPtr& s, std::string_view body);
  void hello(const SessionPtr& s, const v1::Hello& h);
  void command(const SessionPtr& s, const v1::Command& c);

  // ---- server_send.cpp: the write side
  void log_client(const std::string& line);
  static std::string who(const Session& s);
  void pump(const SessionPtr& s);
  bool queue(Session& s, Bytes bytes);
  bool queue_scene(Session& s, Bytes scene);
  bool counted(Session& s, bool within_bound);
  void send(const SessionPtr& s, Bytes bytes);
  void error(const SessionPtr& s, v1::Error::Code code, const std::string& reason);
  void fatal(const SessionPtr& s, v1::Error::Code code, const std::string& reason);
  void close(Session& s, const char* why = "left");

  // ---- server_frames.cpp: what goes out unasked, and housekeeping
  TaskSession* task();
  bool queue_task(Session& s, const TaskSession& t);
  void send_task_to_all();
  void send_scene_to_all();
  Bytes scene_frame();
  void plan_volume(Session& s, const VolumeRequest& r);
  Bytes next_volume_chunk(Session& s);
  void frames_published();
  void want_frames();
  void became_ready(Session& s);
  void drain();
  void schedule_house();
  void housekeeping();
  void send_stats(std::int64_t now);

  ServerConfig config_;
  SceneDescription scene_;
  rt::HapticLoop& loop_;
  ControlTarget* control_;
  asio::io_context io_;
  asio::ip::tcp::acceptor acceptor_;
  FramePump pump_;
  asio::steady_timer house_timer_;
  std::thread thread_;
  std::vector<SessionPtr> sessions_;
  // Queues of dropped clients, freed kFreePerPoll messages per poll.
  static constexpr std::size_t kFreePerPoll = 4096;
  Graveyard graveyard_;
  bool scene_dirty_ = false;         // the scene changed since SceneInfo was last sent
  std::uint64_t task_revision_ = 0;  // the task's revision last sent
  std::uint16_t port_ = 0;
  std::uint64_t next_id_ = 0;
  TokenGuard token_guard_;
  std::int64_t last_stats_ns_ = 0;
  rt::DeviceState last_device_state_ = rt::DeviceState::Present;
  std::uint64_t last_stats_ticks_ = 0;
  std::atomic<std::size_t> client_count_{0};
  std::atomic<std::uint64_t> accepted_{0}, rejected_{0}, protocol_errors_{0}, frames_sent_{0},
      frames_dropped_{0}, timeouts_{0}, overflows_{0};
  // token refusals have a budget of their own, so a flood of other refusals cannot hide them
  ClientLog client_log_, token_log_;
  ForceHistory force_history_;
  // Last: its encoders stop before anything they post to. Wakes the sessions waiting for a chunk.
  VolumeCache volume_cache_{scene_, config_.volume_chunk_bytes,
                            [this] {
                              asio::post(io_, [this] {
                                for (const SessionPtr& s : sessions_)
                                  if (!s->ready && s->volume_frames && !s->writing) pump(s);
                              });
                            },
                            true};
};

}  // namespace palp::net
