// A blocking palp.v1 test client with timeouts, for the loopback tests of palpd.
#pragma once

#include <poll.h>

#include <array>
#include <chrono>
#include <functional>
#include <string>

#include "asio.hpp"
#include "net/protocol.hpp"
#include "wire/framing.hpp"

namespace palp::testing {

using asio::ip::tcp;
namespace v1 = palp::v1;

// A blocking client with timeouts.
class TestClient {
  using Clock = std::chrono::steady_clock;

 public:
  explicit TestClient(std::uint16_t port, int receive_buffer = 0)
      : socket_(io_), decoder_(wire::kDefaultMaxServerFrame) {
    socket_.open(tcp::v4());
    if (receive_buffer > 0)
      socket_.set_option(asio::socket_base::receive_buffer_size(receive_buffer));
    socket_.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  }

  void send_raw(const std::string& bytes) { asio::write(socket_, asio::buffer(bytes)); }
  void send(const v1::ClientMessage& m) { send_raw(wire::encode_frame(m)); }
  void hello(v1::Role role = v1::OBSERVER, const std::string& token = "",
             std::uint32_t version = wire::kProtocolVersion, std::uint32_t volume_max_dim = 0,
             double rate = 0.0, bool contacts = false) {
    v1::ClientMessage m;
    v1::Hello* h = m.mutable_hello();
    h->set_protocol_version(version);
    h->set_role(role);
    h->set_token(token);
    h->set_client_name("server_test");
    h->set_volume_max_dim(volume_max_dim);
    h->set_frame_rate_hz(rate);
    h->set_want_contacts(contacts);
    send(m);
  }

  // The next message, or false on timeout or a closed connection.
  bool next(v1::ServerMessage& out, double timeout_s = 10.0) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
      std::string_view body;
      const wire::FrameStatus st = decoder_.next(body);
      if (st == wire::FrameStatus::Ok) {
        out.Clear();
        return out.ParseFromArray(body.data(), static_cast<int>(body.size()));
      }
      if (st != wire::FrameStatus::Incomplete || closed_) return false;
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      if (left.count() <= 0) return false;
      pollfd p{socket_.native_handle(), POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return false;
      asio::error_code ec;
      const std::size_t n = socket_.read_some(asio::buffer(buffer_), ec);
      if (ec) {
        closed_ = true;
        continue;
      }
      decoder_.feed(buffer_.data(), n);
    }
  }

  // Skips messages until one satisfies `want`; false when none came in time.
  bool wait_for(const std::function<bool(const v1::ServerMessage&)>& want, v1::ServerMessage& out,
                double timeout_s = 10.0) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (Clock::now() < deadline) {
      const double left = std::chrono::duration<double>(deadline - Clock::now()).count();
      if (!next(out, left)) return false;
      if (want(out)) return true;
    }
    return false;
  }
  bool wait_for_case(v1::ServerMessage::MsgCase c, v1::ServerMessage& out,
                     double timeout_s = 10.0) {
    return wait_for([c](const v1::ServerMessage& m) { return m.msg_case() == c; }, out, timeout_s);
  }

  // True once the server closed the connection (reads everything left).
  bool closed_by_server(double timeout_s = 10.0) {
    v1::ServerMessage m;
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (Clock::now() < deadline) {
      if (!next(m, 0.2) && closed_) return true;
    }
    return closed_;
  }

  void close() {
    asio::error_code ec;
    socket_.shutdown(tcp::socket::shutdown_both, ec);
    socket_.close(ec);
  }

 private:
  asio::io_context io_;
  tcp::socket socket_;
  wire::FrameDecoder decoder_;
  std::array<std::uint8_t, 65536> buffer_{};
  bool closed_ = false;
};

}  // namespace palp::testing
