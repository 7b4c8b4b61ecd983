// The force history for late joiners: see force_history.hpp.
#include "net/force_history.hpp"

#include <cmath>

#include "base/errors.hpp"

namespace palp::net {

ForceHistory::ForceHistory(double window_s, double interval_s) {
  if (!(interval_s > 0 && window_s >= interval_s && window_s / interval_s <= 100000.0))
    throw UsageError("force history: needs 0 < interval <= window, at most 100000 samples");
  window_ns_ = std::llround(window_s * 1e9);
  interval_ns_ = std::llround(interval_s * 1e9);
  ring_.resize(static_cast<std::size_t>(std::ceil(window_s / interval_s)) + 1);
}

void ForceHistory::add(std::int64_t t_ns, const Vec3d& force) {
  if (count_ > 0 && t_ns - last_ns_ < interval_ns_) return;
  last_ns_ = t_ns;
  ring_[head_] = {t_ns, force};
  head_ = (head_ + 1) % ring_.size();
  if (count_ < ring_.size()) ++count_;
}

void ForceHistory::fill(v1::ForceHistory* out) const {
  out->set_interval_s(static_cast<double>(interval_ns_) * 1e-9);
  for (std::size_t n = 0; n < count_; ++n) {
    const Sample& s = ring_[(head_ + ring_.size() - count_ + n) % ring_.size()];
    if (s.t_ns < last_ns_ - window_ns_) continue;
    out->add_server_time_ns(s.t_ns);
    out->add_fx(s.force.x);
    out->add_fy(s.force.y);
    out->add_fz(s.force.z);
  }
}

}  // namespace palp::net
