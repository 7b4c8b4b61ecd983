// A palp.v1 byte stream that is either plain TCP or TLS over it, chosen per connection: the one
// thing palpd's sessions and the clients (palp probe, palp ctl, palpview) read and write through.
// Plain until start_tls(); after it every read and write goes through OpenSSL (via Asio's SSL
// layer) on the calling io thread. One read and one write in flight at a time, as with a socket.
#pragma once

#include <memory>
#include <string>
#include <utility>

#include "asio.hpp"
#include "asio/ssl.hpp"

namespace palp::tls {

class Stream {
 public:
  explicit Stream(asio::io_context& io) : socket_(io) {}
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;

  asio::ip::tcp::socket& socket() { return socket_; }
  bool secure() const { return tls_ != nullptr; }
  // Wraps the connected socket in TLS with `context`; handshake() next.
  void start_tls(asio::ssl::context& context) {
    tls_ = std::make_unique<asio::ssl::stream<asio::ip::tcp::socket&>>(socket_, context);
  }
  asio::ssl::stream<asio::ip::tcp::socket&>& tls() { return *tls_; }
  SSL* ssl() { return tls_ ? tls_->native_handle() : nullptr; }

  template <class Buffers, class Handler>
  void async_read_some(const Buffers& buffers, Handler&& handler) {
    if (tls_)
      tls_->async_read_some(buffers, std::forward<Handler>(handler));
    else
      socket_.async_read_some(buffers, std::forward<Handler>(handler));
  }
  template <class Buffers, class Handler>
  void async_write(const Buffers& buffers, Handler&& handler) {
    if (tls_)
      asio::async_write(*tls_, buffers, std::forward<Handler>(handler));
    else
      asio::async_write(socket_, buffers, std::forward<Handler>(handler));
  }
  // Closes the socket at once (no TLS close_notify: the peer sees the connection end).
  void close() {
    asio::error_code ec;
    socket_.shutdown(asio::ip::tcp::socket::shutdown_both, ec);
    socket_.close(ec);
  }

 private:
  asio::ip::tcp::socket socket_;
  std::unique_ptr<asio::ssl::stream<asio::ip::tcp::socket&>> tls_;
};

// Whether the first bytes a client sent open a TLS record (a ClientHello: content type 22, then
// version major 3). A palp.v1 frame opens with its varint length and then the ClientMessage's
// field tag, which is never 3 (field 0 is not a field), so a plain-text Hello of 22 bytes is not
// taken for TLS. `n` bytes of `b` are known (at least 1).
inline bool opens_tls_record(const unsigned char* b, std::size_t n) {
  return b[0] == 0x16 && (n < 2 || b[1] == 0x03);
}

}  // namespace palp::tls
