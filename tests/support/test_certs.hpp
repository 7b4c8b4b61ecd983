// Certificates made at run time for the TLS tests (OpenSSL API, EC P-256): a CA, certificates it
// signs with any validity and names, written as PEM into a scratch directory. Nothing here is
// committed; every key is made fresh per run.
#pragma once

#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>

namespace palp::testing {

struct KeyDeleter {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
struct CertDeleter {
  void operator()(X509* c) const { X509_free(c); }
};

// A key and its certificate, and where they were written.
struct Issued {
  std::unique_ptr<EVP_PKEY, KeyDeleter> key;
  std::unique_ptr<X509, CertDeleter> cert;
  std::string cert_file, key_file;
};

class TestPki {
 public:
  explicit TestPki(std::filesystem::path dir) : dir_(std::move(dir)) {
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  // A self-signed CA.
  Issued ca(const std::string& name) { return issue(name, nullptr, true, -3600, 86400, ""); }
  // A certificate signed by `issuer`, valid from now + from_s to now + to_s, with subjectAltName
  // `san` (e.g. "DNS:localhost,IP:127.0.0.1"; "" for none).
  Issued issue(const std::string& name, const Issued* issuer, bool is_ca = false,
               long from_s = -3600, long to_s = 86400, const std::string& san = "") {
    Issued out;
    out.key.reset(EVP_EC_gen("P-256"));
    if (!out.key) throw std::runtime_error("EVP_EC_gen failed");
    out.cert.reset(X509_new());
    X509* x = out.cert.get();
    X509_set_version(x, 2);
    ASN1_INTEGER_set(X509_get_serialNumber(x), ++serial_);
    X509_gmtime_adj(X509_getm_notBefore(x), from_s);
    X509_gmtime_adj(X509_getm_notAfter(x), to_s);
    X509_set_pubkey(x, out.key.get());
    X509_NAME* subject = X509_get_subject_name(x);
    X509_NAME_add_entry_by_txt(subject, "O", MBSTRING_ASC,
                               reinterpret_cast<const unsigned char*>("palp test"), -1, -1, 0);
    X509_NAME_add_entry_by_txt(subject, "CN", MBSTRING_ASC,
                               reinterpret_cast<const unsigned char*>(name.c_str()), -1, -1, 0);
    X509* issuer_cert = issuer ? issuer->cert.get() : x;
    X509_set_issuer_name(x, X509_get_subject_name(issuer_cert));
    X509V3_CTX ctx;
    X509V3_set_ctx(&ctx, issuer_cert, x, nullptr, nullptr, 0);
    add_ext(x, &ctx, NID_basic_constraints, is_ca ? "critical,CA:TRUE" : "CA:FALSE");
    if (is_ca) add_ext(x, &ctx, NID_key_usage, "critical,keyCertSign,cRLSign");
    if (!san.empty()) add_ext(x, &ctx, NID_subject_alt_name, san.c_str());
    X509_sign(x, issuer ? issuer->key.get() : out.key.get(), EVP_sha256());
    out.cert_file = (dir_ / (name + ".crt")).string();
    out.key_file = (dir_ / (name + ".key")).string();
    FILE* f = std::fopen(out.cert_file.c_str(), "w");
    PEM_write_X509(f, x);
    std::fclose(f);
    f = std::fopen(out.key_file.c_str(), "w");
    PEM_write_PrivateKey(f, out.key.get(), nullptr, nullptr, 0, nullptr, nullptr);
    std::fclose(f);
    ::chmod(out.key_file.c_str(), 0600);
    return out;
  }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  static void add_ext(X509* x, X509V3_CTX* ctx, int nid, const char* value) {
    X509_EXTENSION* e = X509V3_EXT_conf_nid(nullptr, ctx, nid, value);
    X509_add_ext(x, e, -1);
    X509_EXTENSION_free(e);
  }
  std::filesystem::path dir_;
  long serial_ = 0;
};

}  // namespace palp::testing
