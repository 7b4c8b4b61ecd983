// Whether palpd could listen on an address: see server.hpp (check_listen_address).
#include <string>

#include "asio.hpp"
#include "base/errors.hpp"
#include "net/server.hpp"

namespace palp::net {

using asio::ip::tcp;

void check_listen_address(const std::string& bind, std::uint16_t port) {
  asio::error_code ec;
  const asio::ip::address address = asio::ip::make_address(bind, ec);
  if (ec) throw UsageError("--bind: '" + bind + "' is not an IP address");
  if (port == 0) return;
  asio::io_context io;
  tcp::acceptor probe(io);
  const tcp::endpoint endpoint(address, port);
  probe.open(endpoint.protocol(), ec);
  if (!ec) probe.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) probe.bind(endpoint, ec);
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

}  // namespace palp::net
