// TLS 1.3 for palp.v1 (Asio's SSL layer over OpenSSL): the server's context (certificate, key,
// optional client CA) with the checks an administrator expects, the clients' context (a CA and the
// host name, or a pinned SHA-256 fingerprint) and one clear message per failure. Both ends link
// this (palp::tls); see docs/security.md for how a lab sets it up.
#pragma once

#include <ctime>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tls/stream.hpp"

namespace palp::tls {

// ------------------------------------------------------------------ server
struct ServerOptions {
  std::string cert_file;         // PEM: the server's certificate (and its chain)
  std::string key_file;          // PEM: its private key, readable by its owner only
  std::string client_ca_file;    // PEM: when set, clients may (controllers must) present a
                                 // certificate signed by this CA
  std::string controllers_file;  // with client_ca_file: the subjects that may be the
                                 // controller, one per line (tls/controllers.hpp); others observe
  bool enabled() const { return !cert_file.empty() || !key_file.empty(); }
};

// What a client's certificate said after the handshake.
struct PeerCertificate {
  bool presented = false;
  bool verified = false;  // signed by the client CA and valid now
  std::string subject;    // RFC 2253, e.g. "CN=station-3,O=Lab"
  std::string problem;    // why it was not verified (presented, not verified)
};

class ServerContext {
 public:
  // Loads and checks: UsageError for a missing half (cert without key) and for --tls-controllers
  // without --tls-client-ca, ResourceError for an unreadable file, a key group/others can read, a
  // key that does not match the certificate, a certificate that has expired or is not valid yet.
  explicit ServerContext(const ServerOptions& options);
  asio::ssl::context& context() { return context_; }
  bool wants_client_certificates() const { return !options_.client_ca_file.empty(); }
  // Whether a verified client certificate with this subject may be the controller: any, without
  // --tls-controllers; with it, only a subject the file lists.
  bool may_control(const std::string& subject) const;
  const ServerOptions& options() const { return options_; }
  std::string subject() const { return subject_; }
  std::time_t not_after() const { return not_after_; }
  // One line for the start-up log: the certificate, its issuer and until when it is valid.
  std::string describe(std::time_t now) const;
  // Non-empty when the certificate expires within `warn_days` of `now` (or has): say it.
  std::string expiry_warning(std::time_t now, int warn_days = 30) const;
  // expiry_warning() at most once a day (palpd asks at each connection): "" otherwise.
  std::string expiry_reminder(std::time_t now);

 private:
  ServerOptions options_;
  asio::ssl::context context_;
  std::string subject_, issuer_;
  std::vector<std::string> controllers_;  // --tls-controllers (empty: any verified certificate)
  std::time_t not_after_ = 0;
  std::time_t last_reminder_ = 0;
};

// The client's certificate on a handshaken server stream.
PeerCertificate peer_certificate(Stream& stream);

// ------------------------------------------------------------------ client
struct ClientOptions {
  std::string ca_file;    // verify the server's certificate against this CA and the host name
  std::string pin;        // or: the SHA-256 fingerprint of the server's certificate (hex, ':' ok)
  std::string cert_file;  // this client's certificate and key (controllers, when palpd asks)
  std::string key_file;
  bool enabled() const { return !ca_file.empty() || !pin.empty(); }
};

class ClientContext {
 public:
  // UsageError for contradictory or malformed options, ResourceError for unreadable files.
  explicit ClientContext(const ClientOptions& options);
  asio::ssl::context& context() { return context_; }
  const ClientOptions& options() const { return options_; }

 private:
  ClientOptions options_;
  std::string pin_;  // normalised: 64 lower-case hex digits
  asio::ssl::context context_;
  friend void async_connect(Stream&, const asio::ip::tcp::resolver::results_type&,
                            const std::string&, const std::string&, ClientContext*,
                            std::function<void(const std::string&)>);
};

// The shared client-side connect: TCP to the first endpoint that answers, TCP_NODELAY, then,
// with `tls` set, the TLS handshake with the server's certificate checked against the CA and
// `host` (or the pin). `done` gets "" or one message saying what failed (connect refused, wrong
// CA, expired, host name mismatch, wrong pin, a server without TLS).
void async_connect(Stream& stream, const asio::ip::tcp::resolver::results_type& endpoints,
                   const std::string& host, const std::string& port, ClientContext* tls,
                   std::function<void(const std::string& failure)> done);

// "AA:BB:..." SHA-256 fingerprint of a PEM certificate file (what --tls-pin takes).
std::string certificate_fingerprint(const std::string& pem_file);

}  // namespace palp::tls
