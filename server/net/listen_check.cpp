// Binding palpd's listening socket: see listen_check.hpp; and the early check of server.hpp.
#include "net/listen_check.hpp"

#include <string>

#include "base/errors.hpp"
#include "net/server.hpp"

namespace palp::net {

using asio::ip::tcp;

void bind_acceptor(tcp::acceptor& acceptor, const std::string& bind, std::uint16_t port) {
  asio::error_code ec;
  const asio::ip::address address = asio::ip::make_address(bind, ec);
  if (ec) throw UsageError("--bind: '" + bind + "' is not an IP address");
  const tcp::endpoint endpoint(address, port);
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (ec) {
    throw ResourceError("cannot listen on " + bind + ":" + std::to_string(port) + ": " +
                        ec.message() +
                        (ec == asio::error::address_in_use
                             ? " (another palpd, or another program, has the port: stop it, or "
                               "choose another with --port, or the 'port' key of the config; "
                               "--port 0 takes any free port)"
                             : ""));
  }
}

void check_listen_address(const std::string& bind, std::uint16_t port) {
  asio::io_context io;
  tcp::acceptor probe(io);
  bind_acceptor(probe, bind, port);  // port 0 takes any free one; closed again on return
}

}  // namespace palp::net
