// palpd's log of client events: see client_log.hpp.
#include "net/client_log.hpp"

#include <cstdio>

#include <time.h>
#include "asio.hpp"

namespace palp::net {

void ClientLog::say(const std::string& line) {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  const std::int64_t now = static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
  if (now - window_ns_ >= 1'000'000'000) {
    if (held_ > 0)
      std::fprintf(stderr, "palpd: (%llu more client events in the last second not logged)\n",
                   static_cast<unsigned long long>(held_));
    window_ns_ = now;
    count_ = 0;
    held_ = 0;
  }
  if (count_ >= kBurst) {
    ++held_;
    return;
  }
  ++count_;
  std::fprintf(stderr, "palpd: %s\n", line.c_str());
}

std::string describe_client(std::uint64_t id, const std::string& address, bool welcomed,
                            bool controller, const std::string& name) {
  std::string out = "client " + std::to_string(id) + " (" + address;
  if (welcomed) {
    out += controller ? ", controller" : ", observer";
    if (!name.empty()) {
      std::string shown = name.substr(0, 64);
      for (char& c : shown)
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
      out += " '" + shown + "'";
    }
  }
  return out + ")";
}

bool is_loopback_address(const std::string& address) {
  if (address.rfind("127.", 0) == 0 || address == "::1" || address == "localhost") return true;
  asio::error_code ec;
  const asio::ip::address a = asio::ip::make_address(address, ec);
  return !ec && a.is_loopback();
}

}  // namespace palp::net
