// The Hello checks: see admission.hpp.
#include "net/admission.hpp"

#include "net/client_log.hpp"
#include "net/protocol.hpp"
#include "net/tls_accept.hpp"

namespace palp::net {

std::optional<Refusal> check_hello(const v1::Hello& h, const HelloFacts& facts,
                                   const ServerConfig& config, TokenGuard& guard,
                                   std::int64_t now_ns) {
  if (h.protocol_version() != kProtocolVersion)
    return Refusal{v1::Error::VERSION_MISMATCH, "protocol version " +
                                                    std::to_string(h.protocol_version()) +
                                                    " is not supported (this server speaks " +
                                                    std::to_string(kProtocolVersion) + ")"};
  const tls::PeerCertificate none;
  if (auto no = certificate_refusal(config.tls.get(), facts.cert ? *facts.cert : none,
                                    h.role() == v1::CONTROLLER);
      !no.empty())
    return Refusal{v1::Error::UNAUTHORIZED, no};
  if (!h.token().empty() && !facts.secure && !is_loopback_address(facts.address))
    return Refusal{v1::Error::UNAUTHORIZED, clear_text_token_refusal(facts.address)};
  if (h.role() != v1::CONTROLLER) {  // observers fill max_clients; the controller's slot stays
    if (facts.observers >= config.max_clients)
      return Refusal{v1::Error::TOO_MANY_CLIENTS,
                     "the server is full (" + std::to_string(config.max_clients) + " clients)"};
    return std::nullopt;
  }
  if (const std::int64_t wait_ns = guard.wait_ns(facts.address, now_ns); wait_ns > 0)
    return Refusal{v1::Error::UNAUTHORIZED, "too many wrong tokens from " + facts.address +
                                                ": wait " + std::to_string(wait_ns / 1'000'000) +
                                                " ms"};
  if (!config.token.empty() && !same_token(h.token(), config.token)) {
    guard.failed(facts.address, now_ns);  // the back-off; the server's log bounds itself
    return Refusal{v1::Error::UNAUTHORIZED,
                   h.token().empty()
                       ? "CONTROLLER needs the server's token: none was given"
                       : "CONTROLLER needs the server's token: the one given is wrong",
                   true};
  }
  guard.succeeded(facts.address);
  if (facts.controller_taken)
    return Refusal{v1::Error::CONTROLLER_BUSY, "another controller is connected"};
  return std::nullopt;
}

std::string pending_refusal(const ServerConfig& config, const std::string& address,
                            std::size_t pending, std::size_t pending_here) {
  if (pending_here >= config.max_pending_per_address)
    return "too many connections from " + address + " waiting to say Hello (at most " +
           std::to_string(config.max_pending_per_address) + ")";
  if (pending >= config.max_pending)
    return "too many connections waiting to say Hello (at most " +
           std::to_string(config.max_pending) + ")";
  return {};
}

}  // namespace palp::net
