// palpview's network layer under test (client/stream/stream_client): waits for a StreamClient's
// state with a generous timeout, and the options the stream tests connect with (fast stall and
// reconnect, a small render volume). Shared by tests/client/stream/stream_client*_test.cpp.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <thread>

#include "stream/stream_client.hpp"

namespace palp::testing {

inline constexpr double kStreamTimeoutS = 30.0;  // generous: a loaded 2-core machine

// Polls latest() until `want` holds or `timeout_s` passes; returns the last state seen.
inline view::LatestState wait_for(const view::StreamClient& client,
                                  const std::function<bool(const view::LatestState&)>& want,
                                  double timeout_s = kStreamTimeoutS) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  view::LatestState s = client.latest();
  while (!want(s) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
    s = client.latest();
  }
  return s;
}

inline bool is_state(const view::LatestState& s, view::LinkState state) {
  return s.link.state == state;
}

inline view::StreamOptions options_for(std::uint16_t port) {
  view::StreamOptions o;
  o.port = port;
  o.volume_max_dim = 32;
  o.stall_s = 0.3;
  o.reconnect_min_s = 0.05;
  o.reconnect_max_s = 0.4;
  return o;
}

}  // namespace palp::testing
