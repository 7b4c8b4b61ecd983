// See tls_options.hpp.
#include "cli_common/tls_options.hpp"

#include <ctime>

#include "net/client_log.hpp"
#include "tls/client_policy.hpp"

namespace palp::cli {

std::shared_ptr<tls::ServerContext> server_tls(const Args& args) {
  tls::ServerOptions o;
  o.cert_file = args.get("tls-cert").value_or("");
  o.key_file = args.get("tls-key").value_or("");
  o.client_ca_file = args.get("tls-client-ca").value_or("");
  o.controllers_file = args.get("tls-controllers").value_or("");
  if (!o.enabled()) {
    if (!o.client_ca_file.empty())
      throw UsageError("--tls-client-ca needs TLS: give --tls-cert FILE and --tls-key FILE too");
    if (!o.controllers_file.empty())
      throw UsageError(
          "--tls-controllers needs TLS: give --tls-cert FILE, --tls-key FILE and --tls-client-ca "
          "FILE too");
    return nullptr;
  }
  return std::make_shared<tls::ServerContext>(o);
}

std::vector<std::string> server_tls_report(const tls::ServerContext* context,
                                           const std::string& bind) {
  std::vector<std::string> lines;
  const std::time_t now = std::time(nullptr);
  if (context) {
    lines.push_back(context->describe(now));
    if (auto warning = context->expiry_warning(now); !warning.empty()) lines.push_back(warning);
  } else if (!net::is_loopback_address(bind)) {
    lines.push_back("warning: palp.v1 is unencrypted on " + bind +
                    ": frames and the scene (patient data) travel in clear text, and remote "
                    "controllers cannot send the token (give --tls-cert and --tls-key, see "
                    "docs/security.md)");
  }
  return lines;
}

std::unique_ptr<tls::ClientContext> client_tls(const Args& args) {
  tls::ClientOptions o;
  o.ca_file = args.get("tls-ca").value_or("");
  o.pin = args.get("tls-pin").value_or("");
  o.cert_file = args.get("tls-cert").value_or("");
  o.key_file = args.get("tls-key").value_or("");
  tls::check_client_options(o);
  if (!o.enabled()) return nullptr;
  return std::make_unique<tls::ClientContext>(o);
}

}  // namespace palp::cli
