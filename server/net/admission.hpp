// Who may join: the checks a Hello passes before palpd welcomes a client — protocol version,
// the TLS client certificate, no token in clear text off loopback, the controller token with
// its back-off, one controller at a time, at most max_clients observers. No sockets: the server
// gathers the facts and applies the answer.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "net/server.hpp"
#include "net/token_guard.hpp"
#include "palp.pb.h"
#include "tls/tls_context.hpp"

namespace palp::net {

// What the server knows about the connection saying Hello and about the others.
struct HelloFacts {
  const tls::PeerCertificate* cert = nullptr;  // the client's certificate (TLS only)
  bool secure = false;                         // the connection is TLS
  std::string address;                         // remote address
  std::size_t observers = 0;      // welcomed observers still connected, this one left out
  bool controller_taken = false;  // another controller is connected
};

// Why a Hello is refused: the Error sent before closing.
struct Refusal {
  v1::Error::Code code = v1::Error::BAD_REQUEST;
  std::string reason;
  bool token_refused = false;  // a missing or wrong controller token (to be logged on its own)
};

// nullopt: welcome it. The token guard records wrong and right controller tokens at `now_ns`.
std::optional<Refusal> check_hello(const v1::Hello& hello, const HelloFacts& facts,
                                   const ServerConfig& config, TokenGuard& guard,
                                   std::int64_t now_ns);

// Why a connection that has not said Hello yet is refused ("" : it may wait), from how many
// others wait (`pending`) and how many of them from its address (`pending_here`).
std::string pending_refusal(const ServerConfig& config, const std::string& address,
                            std::size_t pending, std::size_t pending_here);

}  // namespace palp::net
