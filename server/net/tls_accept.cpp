// See tls_accept.hpp.
#include "net/tls_accept.hpp"

#include <algorithm>
#include <array>
#include <ctime>

namespace palp::net {

void tls_accept(tls::Stream& stream, tls::ServerContext& context,
                std::function<void(const TlsAccepted&)> done) {
  stream.socket().async_wait(
      asio::ip::tcp::socket::wait_read,
      [&stream, &context, done = std::move(done)](const asio::error_code& ec) {
        TlsAccepted result;
        result.notice = context.expiry_reminder(std::time(nullptr));
        if (ec) {
          result.message = "left before TLS: " + ec.message();
          return done(result);
        }
        std::array<unsigned char, 3> first{};
        asio::error_code peek_ec;
        const std::size_t n =
            stream.socket().receive(asio::buffer(first), asio::socket_base::message_peek, peek_ec);
        if (peek_ec || n == 0) {
          result.message = "left before TLS";
          return done(result);
        }
        if (!tls::opens_tls_record(first.data(), n)) {
          // Read what it sent (a Hello, most likely), so the Error reaches it before the close.
          std::array<unsigned char, 4096> junk{};
          const std::size_t waiting = std::min(stream.socket().available(peek_ec), junk.size());
          (void)stream.socket().receive(asio::buffer(junk, waiting), 0, peek_ec);
          result.kind = TlsAccepted::Kind::PlainText;
          return done(result);
        }
        stream.start_tls(context.context());
        stream.tls().async_handshake(
            asio::ssl::stream_base::server, [&stream, done](const asio::error_code& e) {
              TlsAccepted r;
              if (e) {
                r.message = "TLS handshake failed: " + e.message();
                if (r.message.find("unknown ca") != std::string::npos)
                  r.message += " (the client checks palpd's certificate against another CA)";
                else if (r.message.find("bad certificate") != std::string::npos)
                  r.message += " (the client refused palpd's certificate: its host name or pin)";
                return done(r);
              }
              r.kind = TlsAccepted::Kind::Secure;
              r.client = tls::peer_certificate(stream);
              done(r);
            });
      });
}

std::string plain_text_refusal() {
  return "this palpd speaks palp.v1 over TLS only: connect with --tls-ca FILE (or --tls-pin "
         "SHA256); plain text is refused";
}

std::string clear_text_token_refusal(const std::string& address) {
  return "the controller token is never accepted in plain text from " + address +
         ": anyone on the path could read it; connect over TLS (palpd --tls-cert) or from the "
         "palpd machine itself";
}

std::string certificate_refusal(const tls::ServerContext* context,
                                const tls::PeerCertificate& client, bool controller) {
  if (!context || !context->wants_client_certificates()) return "";
  if (client.presented && !client.verified) return client.problem;
  if (controller && !client.presented)
    return "CONTROLLER needs a client certificate signed by the server's --tls-client-ca: none "
           "was presented (give --tls-cert FILE --tls-key FILE)";
  if (controller && !context->may_control(client.subject))
    return "CONTROLLER: the client certificate " + client.subject + " is not in palpd's " +
           "--tls-controllers " + context->options().controllers_file +
           " (it may connect as an observer)";
  return "";
}

}  // namespace palp::net
