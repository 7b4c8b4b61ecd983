// Token guessing costs time: after three wrong controller tokens an address waits before it may
// try again, 100 ms doubling with each further failure up to 30 s (a mistyped token costs
// nothing). The table is bounded (the least recent address goes first); wrong tokens are to be
// logged at most once a second. Pure bookkeeping: times come in, nothing sleeps.
#pragma once

#include <cstdint>
#include <map>
#include <string>

namespace palp::net {

// Compares a presented token with the server's in time that depends only on the presented
// token's length, not on where the first difference is.
bool same_token(const std::string& presented, const std::string& expected);

class TokenGuard {
 public:
  static constexpr std::size_t kMaxAddresses = 1024;
  static constexpr std::uint32_t kFreeAttempts = 3;

  // How long `address` must still wait at `now_ns` (0: it may try).
  std::int64_t wait_ns(const std::string& address, std::int64_t now_ns) const;
  // A wrong token from `address`. True when this one should be logged (at most once a second).
  bool failed(const std::string& address, std::int64_t now_ns);
  // The right token: the address starts afresh.
  void succeeded(const std::string& address) { failures_.erase(address); }
  std::uint64_t total() const { return total_; }
  std::size_t addresses() const { return failures_.size(); }

 private:
  struct Failures {
    std::uint32_t count = 0;
    std::int64_t retry_ns = 0;
    std::int64_t last_ns = 0;
  };
  std::map<std::string, Failures> failures_;
  std::uint64_t total_ = 0;
  std::int64_t last_log_ns_ = 0;
  bool logged_ = false;
};

}  // namespace palp::net
