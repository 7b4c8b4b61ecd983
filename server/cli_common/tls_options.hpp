// The TLS options of palpd, palp probe and palp ctl (palpview has the same client options):
//   palpd:  --tls-cert FILE --tls-key FILE [--tls-client-ca FILE [--tls-controllers FILE]]
//           (or the config file's keys)
//   client: --tls-ca FILE | --tls-pin SHA256 [--tls-cert FILE --tls-key FILE]
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "cli_common/cli.hpp"
#include "tls/tls_context.hpp"

namespace palp::cli {

inline const std::vector<std::string> kServerTlsOptions = {"tls-cert", "tls-key", "tls-client-ca",
                                                           "tls-controllers"};
inline const std::vector<std::string> kClientTlsOptions = {"tls-ca", "tls-pin", "tls-cert",
                                                           "tls-key"};

// palpd's TLS context, loaded and checked (null without --tls-cert / --tls-key).
std::shared_ptr<tls::ServerContext> server_tls(const Args& args);

// What palpd says at start about encryption: the certificate and its expiry with TLS, or that
// traffic is unencrypted when `bind` is beyond loopback. Lines starting "warning" go to stderr.
std::vector<std::string> server_tls_report(const tls::ServerContext* context,
                                           const std::string& bind);

// A client's TLS context (null when neither --tls-ca nor --tls-pin is given).
std::unique_ptr<tls::ClientContext> client_tls(const Args& args);

}  // namespace palp::cli
