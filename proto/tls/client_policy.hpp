// What a palp.v1 client may do before it connects, decided in one place for palp probe, palp ctl
// and palpview (all link palp::tls): whether its controller token may cross the network in clear
// text, and whether its TLS options say what it will do. palpd refuses a clear-text token from
// beyond loopback too (server/net/admission.cpp), but only once it has crossed the wire: these
// checks keep it from leaving.
#pragma once

#include <string>

#include "tls/tls_context.hpp"

namespace palp::tls {

// The loopback interface: 127.0.0.0/8, ::1, and 127.0.0.0/8 written as IPv4-mapped IPv6.
bool is_loopback(const asio::ip::address& address);

// "" when a client may say Hello with a token to `endpoints` (what `host` resolved to, every
// address it might connect to): it has no token, it speaks TLS, or every address is loopback.
// Otherwise the reason, naming --tls-ca and --tls-pin: the client says it and does not connect.
std::string clear_text_token_refusal(bool has_token, bool tls, const std::string& host,
                                     const asio::ip::tcp::resolver::results_type& endpoints);

// UsageError for a client certificate or key without --tls-ca / --tls-pin (there would be no
// TLS to present it in: the client would connect in plain text) and for one without the other.
void check_client_options(const ClientOptions& options);

}  // namespace palp::tls
