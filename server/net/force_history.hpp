// The force history palpd keeps for late joiners: the device force of the snapshots the network
// thread drains (never the real-time thread), decimated to one sample every `interval_s`, the
// last `window_s` seconds in a ring allocated once. A client that joins gets it as one
// ForceHistory message, so its force chart shows the session's window at once.
#pragma once

#include <cstdint>
#include <vector>

#include "base/vec.hpp"
#include "palp.pb.h"

namespace palp::net {

class ForceHistory {
 public:
  // UsageError unless 0 < interval_s <= window_s (and at most 100 000 samples).
  explicit ForceHistory(double window_s = 10.0, double interval_s = 0.02);

  // A snapshot's deadline and force: kept when interval_s has passed since the last one kept.
  void add(std::int64_t t_ns, const Vec3d& force);
  // The samples within window_s of the newest, oldest first.
  void fill(v1::ForceHistory* out) const;
  std::size_t size() const { return count_; }

 private:
  struct Sample {
    std::int64_t t_ns = 0;
    Vec3d force{};
  };
  std::int64_t window_ns_, interval_ns_;
  std::vector<Sample> ring_;
  std::size_t head_ = 0, count_ = 0;  // next slot to write; samples held
  std::int64_t last_ns_ = 0;
};

}  // namespace palp::net
