// The frame_batch topic's batches (docs/dds.md): palpd's DDS thread adds each frame it publishes
// and writes the batch when it is due. A batch holds the frames whose deadlines lie within
// `window` of loop time from its first; it is due when the next frame would fall outside (the
// frame just added ends the window, or a later frame arrives), when it is full, or, with no
// frame coming, a window after the window's end (frames reach the DDS thread a little after
// their deadlines: sooner would split batches). Frames keep their own frame_index (one
// numbering with the frames topic), so a batch lost on the network or frames dropped inside
// palpd show as gaps. Storage is allocated once, in the constructor.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "palp_types.h"

namespace palp::interop {

class FrameBatcher {
 public:
  // `window_ns` > 0 of loop time per batch; `period_ns` between two frames (1/rate; 0: unknown,
  // a batch then ends at the first frame outside its window). UsageError when a window holds
  // more than palp_dds_kMaxBatchFrames frames.
  FrameBatcher(const std::string& rig, std::int64_t window_ns, std::int64_t period_ns);

  // Frames one batch can hold: the window over the period, one more for a late deadline.
  std::size_t capacity() const { return frames_.size(); }
  // Adding a frame with deadline `t_ns` needs the pending batch written first.
  bool due_before(std::int64_t t_ns) const { return count_ > 0 && t_ns >= start_ns_ + window_ns_; }
  void add(const palp_dds_BatchFrame& frame);
  // The pending batch is complete (full, or the last frame added ends its window).
  bool complete() const;
  // With no more frames: the clock (CLOCK_MONOTONIC, as the deadlines) is a window past the
  // window's end.
  bool stale(std::int64_t now_ns) const {
    return count_ > 0 && now_ns >= start_ns_ + 2 * window_ns_;
  }
  std::size_t size() const { return count_; }
  // The pending batch as a sample (borrowing this object's storage; valid until the next add()
  // or clear()); then clear() starts the next one.
  const palp_dds_FrameBatch& sample();
  void clear();
  void drop() { count_ = 0; }  // forget the pending frames (no reader): batch_index unchanged
  std::uint64_t batches() const { return batch_index_; }  // batches cleared so far

 private:
  std::int64_t window_ns_, period_ns_;
  std::vector<palp_dds_BatchFrame> frames_;
  palp_dds_FrameBatch sample_{};
  std::size_t count_ = 0;
  std::int64_t start_ns_ = 0, last_ns_ = 0;
  std::uint64_t batch_index_ = 0;
};

}  // namespace palp::interop
