// palpd's log of client events (joined, left, refused, dropped) on stderr, for journalctl: a line
// per event, at most kBurst a second per log; what is held back is counted and the count said
// with the next second's first event. Network thread only (not thread-safe, never real time).
#pragma once

#include <cstdint>
#include <string>

namespace palp::net {

class ClientLog {
 public:
  static constexpr int kBurst = 20;
  // Writes "palpd: LINE" unless this second's budget is spent (then counts it).
  void say(const std::string& line);

 private:
  std::int64_t window_ns_ = -1'000'000'000'000;
  int count_ = 0;
  std::uint64_t held_ = 0;
};

// "client 4 (10.0.0.7, observer 'station-2')": the name, a client's own words, cut to 64
// characters with control characters replaced; role and name only once it said Hello.
std::string describe_client(std::uint64_t id, const std::string& address, bool welcomed,
                            bool controller, const std::string& name);

// 127.x.x.x, ::1, localhost (or an address asio reads as loopback).
bool is_loopback_address(const std::string& address);

}  // namespace palp::net
