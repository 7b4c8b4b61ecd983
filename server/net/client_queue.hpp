// What palpd has queued for one client, bounded twice: haptic frames by count (the oldest is
// dropped when full, so a slow client gets the newest frames), and everything together by bytes,
// each message counted with kQueueEntryOverhead. Stale frames are dropped first to stay within
// the byte bound; when the other messages alone (Welcome, errors, pongs, command results, stats)
// exceed it, the client is not reading what it asks for and the server drops it. At most one
// SceneInfo is queued: a newer one replaces it. A dropped client's messages go to a Graveyard,
// freed a slice at a time so that freeing them never stalls the network thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

namespace palp::net {

using Bytes = std::shared_ptr<const std::string>;

// What one queued message costs besides its bytes (shared string, control block, queue slot).
inline constexpr std::size_t kQueueEntryOverhead = 128;

// Queues of dropped clients, waiting to be freed.
class Graveyard {
 public:
  void bury(std::deque<Bytes>&& messages);
  // Frees at most `budget` messages; returns how many are left.
  std::size_t free_some(std::size_t budget);
  std::size_t size() const;

 private:
  std::deque<std::deque<Bytes>> queues_;
};

class ClientQueue {
 public:
  ClientQueue(std::size_t max_frames, std::size_t max_bytes)
      : max_frames_(max_frames), max_bytes_(max_bytes) {}

  // Queue a message / replace the queued SceneInfo: false when the queue exceeds its byte bound
  // even with every frame dropped (the message stays queued; the caller drops the client).
  bool push_message(Bytes message);
  bool push_scene(Bytes scene);
  // Queue a haptic frame, dropping the oldest frames past the count or the byte bound.
  void push_frame(Bytes frame);
  void drop_frames();
  // Moves the messages, then the SceneInfo, then (when `with_frames`) the frames to `out`;
  // returns how many frames it moved.
  std::size_t take(std::vector<Bytes>& out, bool with_frames);
  // Moves everything to `graveyard`, leaving the queue empty.
  void bury(Graveyard& graveyard);

  std::size_t bytes() const { return bytes_; }
  std::size_t frames() const { return frames_.size(); }
  std::uint64_t frames_dropped() const { return frames_dropped_; }

 private:
  static std::size_t cost(const Bytes& b) { return b->size() + kQueueEntryOverhead; }
  void drop_oldest_frame();
  bool within_bound();

  std::size_t max_frames_, max_bytes_;
  std::deque<Bytes> messages_;
  Bytes scene_;
  std::deque<Bytes> frames_;
  std::size_t bytes_ = 0;
  std::uint64_t frames_dropped_ = 0;
};

}  // namespace palp::net
