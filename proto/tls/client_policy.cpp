// See client_policy.hpp.
#include "tls/client_policy.hpp"

#include "base/errors.hpp"

namespace palp::tls {

bool is_loopback(const asio::ip::address& address) {
  if (address.is_v4()) return (address.to_v4().to_uint() >> 24) == 127;
  const asio::ip::address_v6 v6 = address.to_v6();
  if (v6.is_v4_mapped()) return is_loopback(asio::ip::make_address_v4(asio::ip::v4_mapped, v6));
  return v6.is_loopback();
}

std::string clear_text_token_refusal(bool has_token, bool tls, const std::string& host,
                                     const asio::ip::tcp::resolver::results_type& endpoints) {
  if (!has_token || tls) return "";
  std::string outside;
  for (const auto& entry : endpoints) {
    const asio::ip::address address = entry.endpoint().address();
    if (is_loopback(address)) continue;
    outside = address.to_string();
    break;
  }
  if (outside.empty() && !endpoints.empty()) return "";
  const std::string where =
      outside.empty() || outside == host ? "'" + host + "'" : "'" + host + "' (" + outside + ")";
  return "the controller token would cross the network in clear text to " + where +
         ": give --tls-ca FILE or --tls-pin SHA256 to speak TLS (palpd --tls-cert), or connect "
         "from the palpd machine over loopback; nothing was sent";
}

void check_client_options(const ClientOptions& options) {
  if (!options.enabled() && (!options.cert_file.empty() || !options.key_file.empty()))
    throw UsageError(
        "--tls-cert/--tls-key need TLS: give --tls-ca FILE or --tls-pin SHA256 as well (without "
        "them the connection would be plain text and the certificate never shown)");
  if (options.cert_file.empty() != options.key_file.empty())
    throw UsageError("a client certificate needs both --tls-cert FILE and --tls-key FILE");
}

}  // namespace palp::tls
