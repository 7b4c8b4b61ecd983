// palp.v1 over TLS on loopback (server/net/tls_accept.cpp, proto/tls/): certificates made at run
// time; a TLS observer and a controller with a client certificate work end to end; a plain-text
// client, a client trusting another CA, a controller without a certificate, an expired client
// certificate, a host name mismatch and a wrong pin are each refused with their own message while
// the connected clients keep receiving; a relay's capture of a TLS session holds neither the token
// nor a frame's plain encoding (and the same capture of a plain session does: the check can fail);
// a plain-text token from this machine's outside address is refused; with --tls-controllers only
// a listed certificate subject may be the controller; a TLS 1.2 client is refused.
#include "net/tls_accept.hpp"

#include <poll.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <thread>

#include "base/errors.hpp"
#include "net/server.hpp"
#include "support/net_test_client.hpp"
#include "support/outside_address.hpp"
#include "support/palpd_test_util.hpp"
#include "support/test_certs.hpp"
#include "wire/framing.hpp"

namespace palp::net {
namespace {

using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

// A blocking palp.v1 client over tls::Stream (plain when `options` is null), connected with the
// shared client connect of palp probe, palp ctl and palpview.
class SecureClient {
 public:
  SecureClient(std::uint16_t port, const tls::ClientOptions* options,
               const std::string& host = "127.0.0.1")
      : stream_(io_), decoder_(wire::kDefaultMaxServerFrame) {
    if (options) context_ = std::make_unique<tls::ClientContext>(*options);
    tcp::resolver resolver(io_);
    const auto endpoints = resolver.resolve(host, std::to_string(port));
    bool done = false;
    tls::async_connect(stream_, endpoints, host, std::to_string(port), context_.get(),
                       [&](const std::string& f) {
                         failure_ = f;
                         done = true;
                       });
    io_.run_for(std::chrono::seconds(10));
    if (!done) failure_ = "connect timed out";
    io_.restart();
  }
  const std::string& failure() const { return failure_; }

  void hello(v1::Role role, const std::string& token = "") {
    v1::ClientMessage m;
    v1::Hello* h = m.mutable_hello();
    h->set_protocol_version(wire::kProtocolVersion);
    h->set_role(role);
    h->set_token(token);
    h->set_client_name("tls_test");
    send(m);
  }
  void send(const v1::ClientMessage& m) {
    const std::string bytes = wire::encode_frame(m);
    bool done = false;
    stream_.async_write(asio::buffer(bytes),
                        [&](const asio::error_code&, std::size_t) { done = true; });
    while (!done && io_.run_one_for(std::chrono::seconds(5)) > 0) {
    }
    io_.restart();
  }
  bool next(v1::ServerMessage& out, double timeout_s = 10.0) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    for (;;) {
      std::string_view body;
      const wire::FrameStatus st = decoder_.next(body);
      if (st == wire::FrameStatus::Ok) {
        out.Clear();
        return out.ParseFromArray(body.data(), static_cast<int>(body.size()));
      }
      if (st != wire::FrameStatus::Incomplete || closed_ || Clock::now() > deadline) return false;
      bool done = false;
      stream_.async_read_some(asio::buffer(buffer_),
                              [&](const asio::error_code& ec, std::size_t n) {
                                done = true;
                                if (ec)
                                  closed_ = true;
                                else
                                  decoder_.feed(buffer_.data(), n);
                              });
      io_.run_for(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()));
      io_.restart();
      if (!done) {
        stream_.close();
        return false;
      }
    }
  }
  bool wait_case(v1::ServerMessage::MsgCase c, v1::ServerMessage& out, double timeout_s = 10.0) {
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (Clock::now() < deadline)
      if (next(out, 1.0) && out.msg_case() == c) return true;
    return false;
  }

 private:
  asio::io_context io_;
  tls::Stream stream_;
  std::unique_ptr<tls::ClientContext> context_;
  wire::FrameDecoder decoder_;
  std::array<std::uint8_t, 65536> buffer_{};
  std::string failure_;
  bool closed_ = false;
};

// A loopback TCP relay that records every byte both ways (what a tap on the network would see).
class Relay {
 public:
  explicit Relay(std::uint16_t upstream) : acceptor_(io_, tcp::endpoint(tcp::v4(), 0)) {
    acceptor_.set_option(tcp::acceptor::reuse_address(true));
    thread_ = std::thread([this, upstream] {
      asio::error_code ec;
      tcp::socket down(io_), up(io_);
      acceptor_.accept(down, ec);
      if (ec) return;
      up.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), upstream), ec);
      if (ec) return;
      std::thread back([&] { pipe(up, down); });
      pipe(down, up);
      back.join();
    });
  }
  ~Relay() {
    asio::error_code ec;
    acceptor_.close(ec);
    stopping_ = true;
    thread_.join();
  }
  std::uint16_t port() const { return acceptor_.local_endpoint().port(); }
  std::string captured() {
    std::lock_guard lock(mutex_);
    return captured_;
  }
  void stop() { stopping_ = true; }

 private:
  void pipe(tcp::socket& from, tcp::socket& to) {
    std::array<char, 16384> buf{};
    while (!stopping_) {
      pollfd p{from.native_handle(), POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      asio::error_code ec;
      const std::size_t n = from.read_some(asio::buffer(buf), ec);
      if (ec) break;
      {
        std::lock_guard lock(mutex_);
        captured_.append(buf.data(), n);
      }
      asio::write(to, asio::buffer(buf.data(), n), ec);
      if (ec) break;
    }
    asio::error_code ec;
    to.shutdown(tcp::socket::shutdown_both, ec);
  }
  asio::io_context io_;
  tcp::acceptor acceptor_;
  std::thread thread_;
  std::mutex mutex_;
  std::string captured_;
  std::atomic<bool> stopping_{false};
};

class TlsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    pki_ = std::make_unique<testing::TestPki>(std::filesystem::temp_directory_path() /
                                              ("palp_tls_test_" + std::to_string(::getpid())));
    ca_ = pki_->ca("lab-ca");
    other_ca_ = pki_->ca("other-ca");
    server_ =
        pki_->issue("palpd.test", &ca_, false, -3600, 86400 * 90, "DNS:palpd.test,IP:127.0.0.1");
    station_ = pki_->issue("station-1", &ca_);
    expired_ = pki_->issue("station-old", &ca_, false, -86400 * 30, -86400);
    stranger_ = pki_->issue("stranger", &other_ca_);
  }
  void TearDown() override {
    if (server) server->stop();
    if (loop) loop->stop();
    std::filesystem::remove_all(pki_->dir());
  }
  void start(bool with_tls, const std::string& token = "", const std::string& bind = "127.0.0.1") {
    model_ = testing::ball_model("finger:7");
    rt::DeviceConfig dc;
    dc.timeout_s = 10.0;
    remote_.configure(dc);
    remote_.activate();
    rt::LoopConfig lc;
    lc.realtime = false;
    lc.watchdog_late_s = 0;
    lc.device_timeout_s = 0;
    loop = std::make_unique<rt::HapticLoop>(model_, remote_, lc);
    ServerConfig config;
    config.port = 0;
    config.token = token;
    config.bind = bind;
    config.stats_interval_s = 0.2;
    if (with_tls)
      config.tls = std::make_shared<tls::ServerContext>(
          tls::ServerOptions{server_.cert_file, server_.key_file, ca_.cert_file, controllers_});
    SceneDescription scene;
    scene.source = "ball";
    scene.grid = model_->fields().grid();
    scene.device = "remote";
    scene.fields = model_->fields_ptr();
    server = std::make_unique<Server>(config, scene, *loop, nullptr);
    loop->start();
    server->start();
  }
  std::uint16_t port() const { return server->port(); }
  tls::ClientOptions trusting(const testing::Issued& ca, const testing::Issued* own = nullptr) {
    tls::ClientOptions o;
    o.ca_file = ca.cert_file;
    if (own) {
      o.cert_file = own->cert_file;
      o.key_file = own->key_file;
    }
    return o;
  }

  std::unique_ptr<testing::TestPki> pki_;
  testing::Issued ca_, other_ca_, server_, station_, expired_, stranger_;
  std::string controllers_;  // --tls-controllers FILE ("" for none)
  std::shared_ptr<const Model> model_;
  rt::RemoteDevice remote_;
  std::unique_ptr<rt::HapticLoop> loop;
  std::unique_ptr<Server> server;
};

// The client's fatal Error, or its connect failure.
std::string refusal(SecureClient& c, v1::Role role) {
  if (!c.failure().empty()) return c.failure();
  c.hello(role);
  v1::ServerMessage m;
  if (!c.wait_case(v1::ServerMessage::kError, m)) return "(no Error)";
  EXPECT_TRUE(m.error().fatal());
  return m.error().reason();
}

bool receives_frames(SecureClient& c, int n) {
  v1::ServerMessage m;
  for (int i = 0; i < n; ++i)
    if (!c.wait_case(v1::ServerMessage::kFrame, m, 5.0)) return false;
  return true;
}

TEST_F(TlsTest, ObserverAndControllerEndToEndAndEachRefusalHasItsOwnMessage) {
  start(true);
  const tls::ClientOptions observer_options = trusting(ca_);
  SecureClient observer(port(), &observer_options);
  ASSERT_EQ(observer.failure(), "");
  observer.hello(v1::OBSERVER);
  v1::ServerMessage m;
  ASSERT_TRUE(observer.next(m));
  ASSERT_TRUE(m.has_welcome());
  EXPECT_EQ(m.welcome().role(), v1::OBSERVER);
  ASSERT_TRUE(receives_frames(observer, 20));

  const tls::ClientOptions station_options = trusting(ca_, &station_);
  SecureClient controller(port(), &station_options);
  ASSERT_EQ(controller.failure(), "");
  controller.hello(v1::CONTROLLER);
  ASSERT_TRUE(controller.next(m));
  ASSERT_TRUE(m.has_welcome());
  EXPECT_EQ(m.welcome().role(), v1::CONTROLLER);
  // The certificate's subject names the controller in Stats.
  bool named = false;
  for (int i = 0; i < 20 && !named; ++i)
    if (observer.wait_case(v1::ServerMessage::kStats, m, 2.0))
      named = m.stats().controller().find("CN=station-1") != std::string::npos;
  EXPECT_TRUE(named) << m.stats().controller();

  // Each refusal, with its own words.
  testing::TestClient plain(port());
  plain.hello();
  ASSERT_TRUE(plain.wait_for_case(v1::ServerMessage::kError, m));
  EXPECT_NE(m.error().reason().find("over TLS only"), std::string::npos) << m.error().reason();
  EXPECT_TRUE(plain.closed_by_server());

  const tls::ClientOptions wrong_ca = trusting(other_ca_);
  SecureClient stranger_server(port(), &wrong_ca);
  EXPECT_NE(stranger_server.failure().find("wrong CA"), std::string::npos)
      << stranger_server.failure();

  SecureClient no_cert(port(), &observer_options);
  EXPECT_NE(refusal(no_cert, v1::CONTROLLER).find("none was presented"), std::string::npos);

  const tls::ClientOptions old = trusting(ca_, &expired_);
  SecureClient expired(port(), &old);
  EXPECT_NE(refusal(expired, v1::OBSERVER).find("expired on"), std::string::npos);

  const tls::ClientOptions unknown = trusting(ca_, &stranger_);
  SecureClient unknown_cert(port(), &unknown);
  EXPECT_NE(refusal(unknown_cert, v1::CONTROLLER).find("not signed by the CA"), std::string::npos);

  SecureClient wrong_host(port(), &observer_options, "localhost");
  EXPECT_NE(wrong_host.failure().find("host name mismatch"), std::string::npos)
      << wrong_host.failure();

  tls::ClientOptions pinned;
  pinned.pin = tls::certificate_fingerprint(stranger_.cert_file);
  SecureClient wrong_pin(port(), &pinned);
  EXPECT_NE(wrong_pin.failure().find("not the pinned one"), std::string::npos)
      << wrong_pin.failure();
  pinned.pin = tls::certificate_fingerprint(server_.cert_file);
  SecureClient right_pin(port(), &pinned, "localhost");  // a pin needs no host name
  ASSERT_EQ(right_pin.failure(), "");
  right_pin.hello(v1::OBSERVER);
  ASSERT_TRUE(right_pin.next(m) && m.has_welcome());

  // None of that disturbed the clients already connected.
  EXPECT_TRUE(receives_frames(observer, 50));
  EXPECT_TRUE(receives_frames(controller, 50));
}

// What an administrator does (docs/security.md): the subject as openssl prints it, one a line.
std::string openssl_subject(const std::string& cert_file) {
  const std::string command =
      "openssl x509 -noout -subject -nameopt RFC2253 -in '" + cert_file + "' 2>&1";
  std::string out;
  if (FILE* pipe = ::popen(command.c_str(), "r")) {
    char buffer[512];
    while (std::fgets(buffer, sizeof buffer, pipe)) out += buffer;
    ::pclose(pipe);
  }
  return out;
}

// --tls-controllers: a certificate from the lab CA whose subject the file lists may be the
// controller; one it does not list is refused as controller (and may observe).
TEST_F(TlsTest, OnlyListedSubjectsMayBeTheController) {
  const testing::Issued unlisted = pki_->issue("station-9", &ca_);
  const std::string line = openssl_subject(station_.cert_file);
  ASSERT_EQ(line.rfind("subject=", 0), 0u) << line;
  controllers_ = (pki_->dir() / "controllers").string();
  std::ofstream(controllers_) << "# controller stations\n" << line << "\n";
  start(true, "token-0f-the-lab-7731");

  const tls::ClientOptions listed_options = trusting(ca_, &station_);
  SecureClient listed(port(), &listed_options);
  ASSERT_EQ(listed.failure(), "");
  listed.hello(v1::CONTROLLER, "token-0f-the-lab-7731");
  v1::ServerMessage m;
  ASSERT_TRUE(listed.next(m) && m.has_welcome()) << m.DebugString();
  EXPECT_EQ(m.welcome().role(), v1::CONTROLLER);

  const tls::ClientOptions unlisted_options = trusting(ca_, &unlisted);
  SecureClient other(port(), &unlisted_options);
  ASSERT_EQ(other.failure(), "");
  other.hello(v1::CONTROLLER, "token-0f-the-lab-7731");
  ASSERT_TRUE(other.wait_case(v1::ServerMessage::kError, m));
  EXPECT_EQ(m.error().code(), v1::Error::UNAUTHORIZED);
  EXPECT_NE(m.error().reason().find("CN=station-9"), std::string::npos) << m.error().reason();
  EXPECT_NE(m.error().reason().find("--tls-controllers"), std::string::npos) << m.error().reason();

  SecureClient watcher(port(), &unlisted_options);
  ASSERT_EQ(watcher.failure(), "");
  watcher.hello(v1::OBSERVER);
  ASSERT_TRUE(watcher.next(m) && m.has_welcome());
  EXPECT_EQ(m.welcome().role(), v1::OBSERVER);
  EXPECT_TRUE(receives_frames(listed, 20));
}

TEST_F(TlsTest, ControllerListNeedsTheClientCa) {
  controllers_ = (pki_->dir() / "controllers").string();
  std::ofstream(controllers_) << "CN=station-1,O=palp test\n";
  try {
    tls::ServerContext context({server_.cert_file, server_.key_file, "", controllers_});
    ADD_FAILURE() << "--tls-controllers without --tls-client-ca was accepted";
  } catch (const UsageError& e) {
    EXPECT_NE(std::string(e.what()).find("--tls-client-ca"), std::string::npos) << e.what();
  }
}

// palp.v1 is TLS 1.3 only: a client that offers at most TLS 1.2 gets no session.
TEST_F(TlsTest, ATls12ClientIsRefused) {
  start(true);
  const auto handshake = [&](int max_version) {
    asio::io_context io;
    asio::ssl::context context(asio::ssl::context::tls_client);
    SSL_CTX_set_max_proto_version(context.native_handle(), max_version);
    context.set_verify_mode(asio::ssl::verify_none);
    asio::ssl::stream<tcp::socket> stream(io, context);
    stream.next_layer().connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port()));
    asio::error_code ec;
    stream.handshake(asio::ssl::stream_base::client, ec);
    return ec;
  };
  const asio::error_code tls12 = handshake(TLS1_2_VERSION);
  EXPECT_TRUE(tls12) << "a TLS 1.2 client completed its handshake";
  std::printf("TLS 1.2 client: %s\n", tls12.message().c_str());
  EXPECT_FALSE(handshake(TLS1_3_VERSION)) << "the same client with TLS 1.3 must get through";
}

TEST_F(TlsTest, ServerRefusesAnExpiredCertificateAndAKeyOthersCanRead) {
  const testing::Issued old = pki_->issue("palpd-old", &ca_, false, -86400 * 30, -60);
  try {
    tls::ServerContext context({old.cert_file, old.key_file, "", ""});
    ADD_FAILURE() << "an expired certificate was accepted";
  } catch (const ResourceError& e) {
    EXPECT_NE(std::string(e.what()).find("expired on"), std::string::npos) << e.what();
  }
  ::chmod(server_.key_file.c_str(), 0644);
  try {
    tls::ServerContext context({server_.cert_file, server_.key_file, "", ""});
    ADD_FAILURE() << "a world-readable key was accepted";
  } catch (const ResourceError& e) {
    EXPECT_NE(std::string(e.what()).find("chmod 600"), std::string::npos) << e.what();
  }
  ::chmod(server_.key_file.c_str(), 0600);
  const tls::ServerContext ok({server_.cert_file, server_.key_file, "", ""});
  EXPECT_EQ(ok.expiry_warning(std::time(nullptr)), "");  // 90 days left, warned from 30
  EXPECT_NE(ok.expiry_warning(std::time(nullptr), 100).find("expires on"), std::string::npos);
}

// What a tap between station and palpd sees: a controller's token and the frames.
std::string capture(TlsTest& t, std::uint16_t port, const tls::ClientOptions* options,
                    std::string& frame_bytes) {
  Relay relay(port);
  SecureClient c(relay.port(), options);
  EXPECT_EQ(c.failure(), "");
  c.hello(v1::CONTROLLER, "token-0f-the-lab-7731");
  v1::ServerMessage m;
  EXPECT_TRUE(c.next(m) && m.has_welcome());
  EXPECT_TRUE(c.wait_case(v1::ServerMessage::kFrame, m));
  frame_bytes = wire::encode_frame(m);
  EXPECT_TRUE(receives_frames(c, 20));
  (void)t;
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  return relay.captured();
}

TEST_F(TlsTest, CaptureOfATlsSessionHoldsNoTokenAndNoFrame) {
  start(true, "token-0f-the-lab-7731");
  const tls::ClientOptions options = trusting(ca_, &station_);
  std::string frame;
  const std::string tapped = capture(*this, port(), &options, frame);
  EXPECT_GT(tapped.size(), 2000u);
  EXPECT_EQ(tapped.find("token-0f-the-lab-7731"), std::string::npos);
  EXPECT_EQ(tapped.find(frame), std::string::npos);
  EXPECT_EQ(tapped.find("palpd"), std::string::npos);  // the server's name in Welcome
}

// A token in plain text from beyond loopback is refused without being compared; the same
// palpd takes a token-less observer from there, and the token over TLS.
TEST_F(TlsTest, PlainTextTokenFromBeyondLoopbackIsRefused) {
  const std::string address = testing::outside_address();
  if (address.empty()) GTEST_SKIP() << "this machine has no non-loopback IPv4 address";
  start(false, "token-0f-the-lab-7731", "0.0.0.0");
  SecureClient controller(port(), nullptr, address);
  ASSERT_EQ(controller.failure(), "");
  controller.hello(v1::CONTROLLER, "token-0f-the-lab-7731");
  v1::ServerMessage m;
  ASSERT_TRUE(controller.wait_case(v1::ServerMessage::kError, m));
  EXPECT_EQ(m.error().code(), v1::Error::UNAUTHORIZED);
  EXPECT_NE(m.error().reason().find("never accepted in plain text"), std::string::npos)
      << m.error().reason();
  SecureClient observer(port(), nullptr, address);
  observer.hello(v1::OBSERVER);
  ASSERT_TRUE(observer.next(m) && m.has_welcome());
}

TEST_F(TlsTest, TheSameCaptureOfAPlainSessionHoldsBoth) {
  start(false, "token-0f-the-lab-7731");  // loopback: the token is allowed in plain text
  std::string frame;
  const std::string tapped = capture(*this, port(), nullptr, frame);
  EXPECT_NE(tapped.find("token-0f-the-lab-7731"), std::string::npos);
  EXPECT_NE(tapped.find(frame), std::string::npos);
}

}  // namespace
}  // namespace palp::net
