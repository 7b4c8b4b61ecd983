// TLS contexts and the shared client connect: see tls_context.hpp.
#include "tls/tls_context.hpp"

#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "base/errors.hpp"
#include "tls/controllers.hpp"

namespace palp::tls {

using asio::ip::tcp;

namespace {

std::string name_text(const X509_NAME* name) {
  if (!name) return "?";
  BIO* bio = BIO_new(BIO_s_mem());
  X509_NAME_print_ex(bio, name, 0, XN_FLAG_RFC2253);
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio, &data);
  std::string text(data, static_cast<std::size_t>(n));
  BIO_free(bio);
  return text.empty() ? "(empty subject)" : text;
}

std::time_t time_of(const ASN1_TIME* t) {
  std::tm tm{};
  if (!t || ASN1_TIME_to_tm(t, &tm) != 1) return 0;
  return timegm(&tm);
}

std::string date_text(std::time_t t) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[40];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M UTC", &tm);
  return text;
}

std::string hex_fingerprint(X509* cert) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (X509_digest(cert, EVP_sha256(), md, &n) != 1) return "";
  std::string hex;
  char byte[3];
  for (unsigned int i = 0; i < n; ++i) {
    std::snprintf(byte, sizeof byte, "%02x", md[i]);
    hex += byte;
  }
  return hex;
}

std::string with_colons(const std::string& hex) {
  std::string out;
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    if (!out.empty()) out += ':';
    out += static_cast<char>(std::toupper(static_cast<unsigned char>(hex[i])));
    if (i + 1 < hex.size())
      out += static_cast<char>(std::toupper(static_cast<unsigned char>(hex[i + 1])));
  }
  return out;
}

// Refuses a private key that anyone but its owner may read (or change).
void check_key_permissions(const std::string& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0)
    throw ResourceError("cannot read the TLS key " + file + ": " + std::strerror(errno));
  if ((st.st_mode & (S_IRWXG | S_IRWXO)) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw ResourceError("the TLS key " + file + " can be read by its group or by others (mode " +
                        mode + "): chmod 600 " + file + ", owned by the user that runs palp");
  }
}

// One message per way a certificate fails verification.
std::string verify_failure(long err, X509* cert, const std::string& what, const std::string& ca,
                           const std::string& host) {
  const std::string subject = cert ? name_text(X509_get_subject_name(cert)) : "?";
  switch (err) {
    case X509_V_ERR_CERT_HAS_EXPIRED:
      return what + " (" + subject + ") expired on " +
             date_text(time_of(cert ? X509_get0_notAfter(cert) : nullptr)) +
             ": it must be renewed (deploy/make-certs.sh)";
    case X509_V_ERR_CERT_NOT_YET_VALID:
      return what + " (" + subject + ") is not valid yet (from " +
             date_text(time_of(cert ? X509_get0_notBefore(cert) : nullptr)) +
             "): check both machines' clocks";
    case X509_V_ERR_HOSTNAME_MISMATCH:
    case X509_V_ERR_IP_ADDRESS_MISMATCH:
      return what + " (" + subject + ") is not for '" + host +
             "' (host name mismatch): connect by a name the certificate lists";
    case X509_V_ERR_UNABLE_TO_GET_ISSUER_CERT_LOCALLY:
    case X509_V_ERR_UNABLE_TO_GET_ISSUER_CERT:
    case X509_V_ERR_DEPTH_ZERO_SELF_SIGNED_CERT:
    case X509_V_ERR_SELF_SIGNED_CERT_IN_CHAIN:
    case X509_V_ERR_UNABLE_TO_VERIFY_LEAF_SIGNATURE:
    case X509_V_ERR_CERT_SIGNATURE_FAILURE:
      return what + " (" + subject + ") is not signed by the CA in " + ca +
             " (wrong CA): " + X509_verify_cert_error_string(err);
    default:
      return what + " (" + subject + ") was refused: " + X509_verify_cert_error_string(err);
  }
}

std::string handshake_hint(const asio::error_code& ec) {
  const std::string m = ec.message();
  for (const char* plain :
       {"wrong version number", "packet length too long", "record layer failure", "http request",
        "unexpected eof", "stream truncated"})
    if (m.find(plain) != std::string::npos)
      return m + " (the server does not speak TLS here: palpd without --tls-cert, or not palpd)";
  return m;
}

void load_own_certificate(asio::ssl::context& context, const std::string& cert,
                          const std::string& key) {
  check_key_permissions(key);
  asio::error_code ec;
  context.use_certificate_chain_file(cert, ec);
  if (ec) throw ResourceError("cannot read the TLS certificate " + cert + ": " + ec.message());
  context.use_private_key_file(key, asio::ssl::context::pem, ec);
  if (ec) throw ResourceError("cannot read the TLS key " + key + ": " + ec.message());
  if (SSL_CTX_check_private_key(context.native_handle()) != 1)
    throw ResourceError("the TLS key " + key + " does not belong to the certificate " + cert);
}

void load_ca(asio::ssl::context& context, const std::string& ca, const char* option) {
  asio::error_code ec;
  context.load_verify_file(ca, ec);
  if (ec)
    throw ResourceError(std::string("cannot read the CA certificate ") + option + " " + ca + ": " +
                        ec.message());
}

}  // namespace

// ------------------------------------------------------------------ server
ServerContext::ServerContext(const ServerOptions& options)
    : options_(options), context_(asio::ssl::context::tls_server) {
  if (options_.cert_file.empty() || options_.key_file.empty())
    throw UsageError("TLS needs both --tls-cert FILE and --tls-key FILE");
  SSL_CTX* ctx = context_.native_handle();
  SSL_CTX_set_min_proto_version(ctx, TLS1_3_VERSION);
  load_own_certificate(context_, options_.cert_file, options_.key_file);
  X509* cert = SSL_CTX_get0_certificate(ctx);
  subject_ = name_text(X509_get_subject_name(cert));
  issuer_ = name_text(X509_get_issuer_name(cert));
  not_after_ = time_of(X509_get0_notAfter(cert));
  if (X509_cmp_current_time(X509_get0_notAfter(cert)) < 0)
    throw ResourceError("the TLS certificate " + options_.cert_file + " (" + subject_ +
                        ") expired on " + date_text(not_after_) +
                        ": make a new one (deploy/make-certs.sh)");
  if (X509_cmp_current_time(X509_get0_notBefore(cert)) > 0)
    throw ResourceError("the TLS certificate " + options_.cert_file + " is not valid before " +
                        date_text(time_of(X509_get0_notBefore(cert))) + ": check the clock");
  if (!options_.client_ca_file.empty()) {
    load_ca(context_, options_.client_ca_file, "--tls-client-ca");
    if (STACK_OF(X509_NAME)* names = SSL_load_client_CA_file(options_.client_ca_file.c_str()))
      SSL_CTX_set_client_CA_list(ctx, names);
    // Asked for, not required: observers may come without one; Hello decides (controllers must
    // have a verified one). Accepted here whatever it is, so the refusal can say why in palp.v1.
    context_.set_verify_mode(asio::ssl::verify_peer);
    context_.set_verify_callback([](bool, asio::ssl::verify_context&) { return true; });
  }
  if (!options_.controllers_file.empty()) {
    if (options_.client_ca_file.empty())
      throw UsageError(
          "--tls-controllers needs --tls-client-ca: a subject names a controller only on a "
          "certificate that CA has verified");
    controllers_ = read_controller_subjects(options_.controllers_file);
  }
}

bool ServerContext::may_control(const std::string& subject) const {
  if (controllers_.empty()) return true;
  return std::find(controllers_.begin(), controllers_.end(), subject) != controllers_.end();
}

std::string ServerContext::describe(std::time_t now) const {
  const long days = static_cast<long>((not_after_ - now) / 86400);
  std::string text = "TLS 1.3 on: certificate " + subject_ + " issued by " + issuer_ +
                     ", valid until " + date_text(not_after_) + " (" + std::to_string(days) +
                     " days left)";
  text += options_.client_ca_file.empty()
              ? "; no --tls-client-ca: controllers are known by their token only"
              : "; controllers need a client certificate signed by " + options_.client_ca_file;
  if (!controllers_.empty())
    text += ", with a subject listed in " + options_.controllers_file + " (" +
            std::to_string(controllers_.size()) + ")";
  return text;
}

std::string ServerContext::expiry_warning(std::time_t now, int warn_days) const {
  const double days = static_cast<double>(not_after_ - now) / 86400.0;
  if (days > warn_days) return "";
  if (days <= 0)
    return "warning: the TLS certificate " + options_.cert_file + " expired on " +
           date_text(not_after_) + ": clients will refuse palpd until it is renewed";
  return "warning: the TLS certificate " + options_.cert_file + " expires on " +
         date_text(not_after_) + " (in " + std::to_string(static_cast<long>(days)) +
         " days): renew it (deploy/make-certs.sh) and restart palpd";
}

std::string ServerContext::expiry_reminder(std::time_t now) {
  if (now - last_reminder_ < 86400) return "";
  std::string warning = expiry_warning(now);
  if (!warning.empty()) last_reminder_ = now;
  return warning;
}

PeerCertificate peer_certificate(Stream& stream) {
  PeerCertificate peer;
  SSL* ssl = stream.ssl();
  if (!ssl) return peer;
  X509* cert = SSL_get1_peer_certificate(ssl);
  if (!cert) return peer;
  peer.presented = true;
  peer.subject = name_text(X509_get_subject_name(cert));
  const long result = SSL_get_verify_result(ssl);
  peer.verified = result == X509_V_OK;
  if (!peer.verified)
    peer.problem = verify_failure(result, cert, "its client certificate", "--tls-client-ca", "");
  X509_free(cert);
  return peer;
}

// ------------------------------------------------------------------ client
ClientContext::ClientContext(const ClientOptions& options)
    : options_(options), context_(asio::ssl::context::tls_client) {
  if (!options_.ca_file.empty() && !options_.pin.empty())
    throw UsageError("give --tls-ca FILE or --tls-pin SHA256, not both");
  if (options_.ca_file.empty() && options_.pin.empty())
    throw UsageError("TLS needs --tls-ca FILE (or --tls-pin SHA256) to check the server");
  if (options_.cert_file.empty() != options_.key_file.empty())
    throw UsageError("a client certificate needs both --tls-cert FILE and --tls-key FILE");
  SSL_CTX_set_min_proto_version(context_.native_handle(), TLS1_3_VERSION);
  for (const char c : options_.pin) {
    if (c == ':') continue;
    if (!std::isxdigit(static_cast<unsigned char>(c))) {
      pin_.clear();
      break;
    }
    pin_ += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  if (!options_.pin.empty() && pin_.size() != 64)
    throw UsageError(
        "--tls-pin takes the server certificate's SHA-256 fingerprint, 64 hex digits "
        "(':' allowed), as `openssl x509 -noout -fingerprint -sha256 -in CERT` "
        "prints it");
  if (!options_.ca_file.empty()) load_ca(context_, options_.ca_file, "--tls-ca");
  if (!options_.cert_file.empty())
    load_own_certificate(context_, options_.cert_file, options_.key_file);
  context_.set_verify_mode(asio::ssl::verify_peer);
}

void async_connect(Stream& stream, const tcp::resolver::results_type& endpoints,
                   const std::string& host, const std::string& port, ClientContext* tls,
                   std::function<void(const std::string& failure)> done) {
  const std::string where = host + ":" + port;
  asio::async_connect(
      stream.socket(), endpoints,
      [&stream, host, where, tls, done = std::move(done)](const asio::error_code& ec,
                                                          const tcp::endpoint&) {
        if (ec) return done("cannot connect to " + where + ": " + ec.message());
        asio::error_code ignored;
        stream.socket().set_option(tcp::no_delay(true), ignored);
        if (!tls) return done("");
        stream.start_tls(tls->context());
        SSL* ssl = stream.ssl();
        asio::error_code not_address;
        (void)asio::ip::make_address(host, not_address);
        if (not_address) SSL_set_tlsext_host_name(ssl, host.c_str());
        auto reason = std::make_shared<std::string>();
        if (!tls->pin_.empty()) {
          stream.tls().set_verify_callback(
              [pin = tls->pin_, reason](bool, asio::ssl::verify_context& vc) {
                X509_STORE_CTX* x = vc.native_handle();
                if (X509_STORE_CTX_get_error_depth(x) != 0) return true;  // the pin is the trust
                const std::string fingerprint = hex_fingerprint(X509_STORE_CTX_get_current_cert(x));
                if (fingerprint == pin) return true;
                if (reason->empty())
                  *reason = "the server's certificate (SHA-256 " + with_colons(fingerprint) +
                            ") is not the pinned one (--tls-pin " + with_colons(pin) +
                            "): another server, or its certificate was replaced";
                return false;
              });
        } else {
          X509_VERIFY_PARAM* param = SSL_get0_param(ssl);
          if (not_address)
            X509_VERIFY_PARAM_set1_host(param, host.c_str(), 0);
          else
            X509_VERIFY_PARAM_set1_ip_asc(param, host.c_str());
          stream.tls().set_verify_callback([reason, host, ca = tls->options_.ca_file](
                                               bool ok, asio::ssl::verify_context& vc) {
            if (ok) return true;
            X509_STORE_CTX* x = vc.native_handle();
            if (reason->empty())
              *reason =
                  verify_failure(X509_STORE_CTX_get_error(x), X509_STORE_CTX_get_current_cert(x),
                                 "the server's certificate", ca, host);
            return false;
          });
        }
        stream.tls().async_handshake(
            asio::ssl::stream_base::client, [reason, where, done](const asio::error_code& e) {
              if (!e) return done("");
              if (!reason->empty()) return done("TLS refused " + where + ": " + *reason);
              done("TLS handshake with " + where + " failed: " + handshake_hint(e));
            });
      });
}

std::string certificate_fingerprint(const std::string& pem_file) {
  BIO* bio = BIO_new_file(pem_file.c_str(), "r");
  if (!bio) throw ResourceError("cannot read the certificate " + pem_file);
  X509* cert = PEM_read_bio_X509(bio, nullptr, nullptr, nullptr);
  BIO_free(bio);
  if (!cert) throw ResourceError(pem_file + " holds no PEM certificate");
  const std::string fingerprint = with_colons(hex_fingerprint(cert));
  X509_free(cert);
  return fingerprint;
}

}  // namespace palp::tls
