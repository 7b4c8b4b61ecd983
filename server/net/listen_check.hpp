// Binding palpd's listening socket, shared by the server and the early check: one routine, so
// both refuse alike and say the same about a port in use.
#pragma once

#include <cstdint>
#include <string>

#include "asio.hpp"

namespace palp::net {

// Opens `acceptor` on bind:port with SO_REUSEADDR and binds it (no listen). UsageError for a
// bind that is not an IP address; ResourceError naming the address and, for a port in use, what
// to change.
void bind_acceptor(asio::ip::tcp::acceptor& acceptor, const std::string& bind, std::uint16_t port);

}  // namespace palp::net
