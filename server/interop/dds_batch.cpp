#include "interop/dds_batch.hpp"

#include <algorithm>
#include <cstdio>

#include "base/errors.hpp"

namespace palp::interop {

FrameBatcher::FrameBatcher(const std::string& rig, std::int64_t window_ns, std::int64_t period_ns)
    : window_ns_(window_ns), period_ns_(period_ns) {
  if (window_ns_ <= 0) throw UsageError("a frame batch needs a window of loop time > 0");
  const auto most = static_cast<std::int64_t>(palp_dds_kMaxBatchFrames);
  std::int64_t n = most;  // period unknown: as many as the type allows
  if (period_ns_ > 0) {
    const std::int64_t per_window = (window_ns_ + period_ns_ - 1) / period_ns_;
    if (per_window > most)
      throw UsageError("a frame batch of " + std::to_string(window_ns_ / 1000000) +
                       " ms holds more than " + std::to_string(most) +
                       " frames at this rate: use a shorter batch");
    n = std::min(per_window + 1, most);
  }
  frames_.resize(static_cast<std::size_t>(n));
  std::snprintf(sample_.rig, sizeof sample_.rig, "%s", rig.c_str());
}

void FrameBatcher::add(const palp_dds_BatchFrame& frame) {
  if (count_ == frames_.size()) return;  // full: the caller writes complete() batches first
  if (count_ == 0) start_ns_ = frame.server_time_ns;
  last_ns_ = frame.server_time_ns;
  frames_[count_++] = frame;
}

bool FrameBatcher::complete() const {
  if (count_ == 0) return false;
  if (count_ == frames_.size()) return true;
  // The next frame, a period on, would lie outside the window.
  return period_ns_ > 0 && last_ns_ + period_ns_ >= start_ns_ + window_ns_;
}

const palp_dds_FrameBatch& FrameBatcher::sample() {
  sample_.batch_index = batch_index_;
  sample_.frames._maximum = static_cast<std::uint32_t>(frames_.size());
  sample_.frames._length = static_cast<std::uint32_t>(count_);
  sample_.frames._buffer = frames_.data();
  sample_.frames._release = false;
  return sample_;
}

void FrameBatcher::clear() {
  if (count_ == 0) return;
  count_ = 0;
  ++batch_index_;
}

}  // namespace palp::interop
