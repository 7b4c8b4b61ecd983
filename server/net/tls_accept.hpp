// palpd's side of a TLS connection before palp.v1 starts: looks at the first bytes a client sent
// (a TLS ClientHello, or plain text that a TLS-only palpd refuses with a palp.v1 Error it can
// read), runs the handshake and reads the client's certificate. Runs on the io thread only.
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "tls/tls_context.hpp"

namespace palp::net {

struct TlsAccepted {
  enum class Kind { Secure, PlainText, Failed } kind = Kind::Failed;
  std::string message;          // Failed: why (for the log)
  tls::PeerCertificate client;  // Secure: its certificate, if it showed one
  std::string notice;           // a reminder for the log (the certificate expires soon)
};

// Waits for the client's first bytes on `stream` (a connected, still plain socket), then calls
// `done` once. The session's own timeouts bound the wait (close the socket to end it).
void tls_accept(tls::Stream& stream, tls::ServerContext& context,
                std::function<void(const TlsAccepted&)> done);

// The Error text for a plain-text client of a TLS-only palpd.
std::string plain_text_refusal();

// The Error for a controller token sent in plain text from beyond loopback (never compared).
std::string clear_text_token_refusal(const std::string& address);

// What Hello must refuse for this certificate in this role ("" when it may go on): a controller
// needs a verified one when the server asks for client certificates, and with --tls-controllers
// one whose subject the file lists; a certificate that fails verification is refused in any role.
std::string certificate_refusal(const tls::ServerContext* context,
                                const tls::PeerCertificate& client, bool controller);

}  // namespace palp::net
