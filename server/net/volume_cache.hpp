// The render volume's chunk frames, encoded once per plan and shared by every session that asks
// for that plan (a late joiner, a reconnect, several stations), by worker threads in parallel,
// off the io thread.
//
// Data flow: Hello -> plan() (plan_volume with the body's box, found once here) -> get(plan):
// the plan's Frames (a new entry starts `threads` encoders: fill_volume_chunk + the frame, chunk
// by chunk, each publishing its frame and calling `notify`) -> the io thread takes frame(i) as
// soon as it is there (null: not yet; it is woken by `notify`).
//
// Bounds: at most `max_plans` plans are kept (the oldest goes first); a session keeps the Frames
// it sends from, so memory is those plans plus the sessions' (palpd bounds the clients).
// Encoders hold their plan weakly: a plan no session and not the cache wants stops encoding at
// its next chunk. Finished encoders are joined at the next get(). The encoders only read the
// scene (const); the destructor stops and joins them.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "net/client_queue.hpp"
#include "net/scene_messages.hpp"

namespace palp::net {

// What palpview asks by default (--volume-max-dim 256, the CT without d_bone, deflated, cropped,
// with the structures' labels): palpd encodes it at start, so the first station need not wait.
inline constexpr VolumeRequest kViewerDefaultRequest{0, 256, true, false, true, true, true};

class VolumeCache {
 public:
  // One plan's frames (ServerMessage{volume} frames, chunk order).
  class Frames {
   public:
    explicit Frames(const VolumePlan& plan) : plan_(plan), frames_(plan.chunks) {}
    Bytes frame(std::uint32_t index) const;  // null until encoded
    const VolumePlan& plan() const { return plan_; }
    std::uint32_t encoded() const { return encoded_.load(); }

   private:
    friend class VolumeCache;
    VolumePlan plan_;
    mutable std::mutex mutex_;
    std::vector<Bytes> frames_;
    std::atomic<std::uint32_t> next_{0}, encoded_{0};
    std::atomic<bool> stop_{false};
  };

  // `scene` must outlive the cache. `threads` 0: the hardware's cores. `warm`: start encoding
  // kViewerDefaultRequest now (when the scene has maps).
  VolumeCache(const SceneDescription& scene, std::size_t chunk_bytes, std::function<void()> notify,
              bool warm = false, unsigned threads = 0, std::size_t max_plans = 2);
  ~VolumeCache();
  VolumeCache(const VolumeCache&) = delete;
  VolumeCache& operator=(const VolumeCache&) = delete;

  VolumePlan plan(const VolumeRequest& request) const;
  // The frames of `plan` (plan.chunks > 0), encoding started on first ask.
  std::shared_ptr<const Frames> get(const VolumePlan& plan);
  const VoxelBox& body_box() const { return body_box_; }

 private:
  struct Worker {
    std::thread thread;
    std::weak_ptr<Frames> frames;
    std::shared_ptr<std::atomic<bool>> done;
  };
  static void yield_to_live_frames();
  void encode(const std::weak_ptr<Frames>& frames) const;

  const SceneDescription& scene_;
  std::size_t chunk_bytes_;
  std::function<void()> notify_;
  unsigned threads_;
  std::size_t max_plans_;
  VoxelBox body_box_;
  std::mutex mutex_;  // entries_ and workers_ (get() and the destructor)
  std::vector<std::shared_ptr<Frames>> entries_;
  std::vector<Worker> workers_;
};

}  // namespace palp::net
