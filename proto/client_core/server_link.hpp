// The connection of a command-line console (palp probe, palp ctl) to palpd: ClientMessages
// written one at a time (TLS allows one write in flight), ServerMessages decoded from the bytes
// as they come (ServerMessageReader, as palpview's connection thread decodes them). The console connects the stream (tls::async_connect), then calls read() once;
// every message and failure goes to its handlers until close().
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <string>
#include <utility>

#include "asio.hpp"
#include "client_core/message_reader.hpp"
#include "base/errors.hpp"
#include "palp.pb.h"
#include "tls/client_policy.hpp"
#include "tls/stream.hpp"
#include "wire/messages.hpp"

namespace palp::client {

// The console's peer resolved; a token never leaves in clear text for another machine
// (tls/client_policy.hpp): UsageError when `has_token` without `tls` to a non-loopback address,
// Error when the name does not resolve.
inline asio::ip::tcp::resolver::results_type resolve_peer(asio::io_context& io,
                                                          const std::string& host,
                                                          const std::string& port, bool has_token,
                                                          bool tls) {
  asio::ip::tcp::resolver resolver(io);
  asio::error_code ec;
  auto endpoints = resolver.resolve(host, port, ec);
  if (ec) throw Error("cannot resolve " + host + ":" + port + ": " + ec.message());
  if (const std::string no = tls::clear_text_token_refusal(has_token, tls, host, endpoints);
      !no.empty())
    throw UsageError(no);
  return endpoints;
}

class ServerLink {
 public:
  struct Handlers {
    std::function<void(std::size_t)> bytes;  // bytes read, before they are decoded (optional)
    std::function<void(const v1::ServerMessage&)> message;
    std::function<void(const std::string&)> fail;  // the reason; the console then close()s
  };

  // `peer` names palpd in the failure messages ("palpd", "the server").
  ServerLink(asio::io_context& io, std::string peer, Handlers handlers)
      : stream_(io),
        peer_(std::move(peer)),
        handlers_(std::move(handlers)),
        reader_(peer_) {}

  tls::Stream& stream() { return stream_; }
  bool closed() const { return closed_; }
  void close() {
    closed_ = true;
    stream_.close();
  }

  void send(const v1::ClientMessage& m) {
    outbox_.push_back(wire::encode_frame(m));
    if (outbox_.size() == 1) write_next();
  }

  void read() {
    stream_.async_read_some(
        asio::buffer(buffer_), [this](const asio::error_code& ec, std::size_t n) {
          if (closed_) return;
          if (ec) {
            return handlers_.fail(ec == asio::error::eof ? peer_ + " closed the connection"
                                                         : "connection lost: " + ec.message());
          }
          if (handlers_.bytes) handlers_.bytes(n);
          reader_.feed(buffer_.data(), n);
          for (;;) {
            v1::ServerMessage m;
            std::string why;
            const ServerMessageReader::Next next = reader_.next(m, why);
            if (next == ServerMessageReader::Next::Incomplete) break;
            if (next == ServerMessageReader::Next::Broken) return handlers_.fail(why);
            handlers_.message(m);
            if (closed_) return;
          }
          read();
        });
  }

 private:
  void write_next() {
    stream_.async_write(asio::buffer(outbox_.front()),
                        [this](const asio::error_code& ec, std::size_t) {
                          if (ec || closed_) return;
                          outbox_.pop_front();
                          if (!outbox_.empty()) write_next();
                        });
  }

  tls::Stream stream_;
  std::string peer_;
  Handlers handlers_;
  std::deque<std::string> outbox_;
  ServerMessageReader reader_;
  std::array<std::uint8_t, 65536> buffer_{};
  bool closed_ = false;
};

}  // namespace palp::client
