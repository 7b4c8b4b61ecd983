// The render volume's chunks as DDS delivers them (palpd --dds; docs/dds.md): keyed by index, in
// any order, and possibly before the scene they need (each topic is matched and its latched
// samples delivered on its own). They are kept until all `count` are there and the scene has
// come, then handed over once in index order. Without this, a chunk taken before the scene was
// dropped, and since palpd publishes the volume once, the station waited for it forever.
#pragma once

#include <cstdint>
#include <map>
#include <utility>

#include "palp.pb.h"

namespace palp::view {

class DdsVolumeChunks {
 public:
  // The most chunks one volume may announce (palpd plans 1 MiB chunks: 4096 is 4 GiB, past any
  // render volume the client accepts, volume_assembly.cpp).
  static constexpr std::uint32_t kMaxChunks = 4096;

  // Keeps chunk `index` of `count`; a chunk of another count than those held replaces them (a
  // new volume). False, and nothing kept, for an index outside the count or a count of 0 or
  // over kMaxChunks.
  bool add(std::uint32_t index, std::uint32_t count, v1::VolumeChunk chunk) {
    if (count == 0 || count > kMaxChunks || index >= count) return false;
    if (count != count_) {
      chunks_.clear();
      count_ = count;
    }
    chunks_[index] = std::move(chunk);
    return true;
  }

  bool complete() const { return count_ > 0 && chunks_.size() == count_; }

  // When complete: fn(chunk) for each in index order, then nothing is held. False otherwise.
  template <class Fn>
  bool hand_over(Fn&& fn) {
    if (!complete()) return false;
    for (const auto& [index, chunk] : chunks_) fn(chunk);
    chunks_.clear();
    count_ = 0;
    return true;
  }

  std::size_t held() const { return chunks_.size(); }

 private:
  std::map<std::uint32_t, v1::VolumeChunk> chunks_;
  std::uint32_t count_ = 0;
};

}  // namespace palp::view
