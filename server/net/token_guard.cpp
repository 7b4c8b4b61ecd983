// Wrong-token back-off per address: see token_guard.hpp.
#include "net/token_guard.hpp"

#include <algorithm>

namespace palp::net {

std::int64_t TokenGuard::wait_ns(const std::string& address, std::int64_t now_ns) const {
  const auto it = failures_.find(address);
  return it == failures_.end() ? 0 : std::max<std::int64_t>(0, it->second.retry_ns - now_ns);
}

bool TokenGuard::failed(const std::string& address, std::int64_t now_ns) {
  if (failures_.size() >= kMaxAddresses && !failures_.count(address)) {
    auto oldest = failures_.begin();
    for (auto it = failures_.begin(); it != failures_.end(); ++it)
      if (it->second.last_ns < oldest->second.last_ns) oldest = it;
    failures_.erase(oldest);
  }
  Failures& f = failures_[address];
  f.count = std::min<std::uint32_t>(f.count + 1, 20);
  if (f.count >= kFreeAttempts) {
    const std::int64_t wait = std::min<std::int64_t>(
        std::int64_t{100'000'000} << std::min<std::uint32_t>(f.count - kFreeAttempts, 9),
        30'000'000'000);
    f.retry_ns = now_ns + wait;
  }
  f.last_ns = now_ns;
  ++total_;
  if (logged_ && now_ns - last_log_ns_ < 1'000'000'000) return false;
  logged_ = true;
  last_log_ns_ = now_ns;
  return true;
}

bool same_token(const std::string& presented, const std::string& expected) {
  unsigned char diff = presented.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < presented.size(); ++i)
    diff |= static_cast<unsigned char>(presented[i] ^ (i < expected.size() ? expected[i] : 0));
  return diff == 0;
}

}  // namespace palp::net
