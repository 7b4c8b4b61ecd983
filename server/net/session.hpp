// One client connection of palpd's server: its stream, decoder, bounded queue and where it is
// in the protocol (Hello, scene and volume, frames). Owned and touched by the io thread only.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "asio.hpp"
#include "net/client_queue.hpp"
#include "net/frame_schedule.hpp"
#include "net/scene_messages.hpp"
#include "net/server.hpp"
#include "net/volume_cache.hpp"
#include "palp.pb.h"
#include "tls/stream.hpp"
#include "tls/tls_context.hpp"
#include "wire/framing.hpp"

namespace palp::net {

struct ServerSession {
  ServerSession(asio::io_context& io, const ServerConfig& config)
      : stream(io),
        decoder(config.max_frame_bytes),
        queue(config.queue_frames, config.max_queue_bytes) {}
  tls::Stream stream;         // plain, or TLS once the handshake began
  tls::PeerCertificate cert;  // the client's certificate (TLS with --tls-client-ca)
  std::uint64_t id = 0;
  std::string name;
  std::string address;  // the remote address, for the per-address Hello budget
  std::string refusal;  // over the Hello budget: said after the TLS handshake (it could not
                        // be read before), a plain server says it at once
  v1::Role role = v1::ROLE_UNSPECIFIED;
  bool welcomed = false;  // Hello accepted
  bool ready = false;     // scene and volume sent: frames flow
  bool closing = false;   // a fatal error is queued: close once written
  bool closed = false;
  bool reading = false, handshaking = false;
  bool writing = false;
  bool want_contacts = false;
  bool end_logged = false;  // its leaving (or refusal) is in the log
  bool landmarks_sent = false;  // the training task's landmarks (task_messages.hpp)
  FrameSchedule frames;     // its requested frame rate: which snapshots it takes
  wire::FrameDecoder decoder;
  std::array<std::uint8_t, 8192> rbuf{};
  ClientQueue queue;
  std::vector<Bytes> inflight;
  std::vector<asio::const_buffer> buffers;
  std::int64_t connected_ns = 0, last_rx_ns = 0, write_started_ns = 0;
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_dropped_counted = 0;  // of queue.frames_dropped(), in frames_dropped_
  // Volume streaming: the plan's frames (volume_cache.hpp), the next one to send.
  VolumePlan volume;
  std::shared_ptr<const VolumeCache::Frames> volume_frames;
  Bytes history;  // ForceHistory, sent once after SceneInfo
  std::uint32_t volume_chunk = 0;
};

}  // namespace palp::net
