// palpview's network layer over TLS (client/stream with proto/tls): against the real palpd with
// --tls-cert/--tls-key/--tls-client-ca and certificates made at run time, a controller station
// with its certificate goes Live (palpd names it by its certificate), and a station trusting
// another CA says so instead of connecting.
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <thread>

#include "stream/stream_client.hpp"
#include "support/palpd_process.hpp"
#include "support/test_certs.hpp"

namespace palp::view {
namespace {

LatestState wait_until(StreamClient& client, const std::function<bool(const LatestState&)>& want,
                       double timeout_s = 30.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  LatestState s = client.latest();
  while (!want(s) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    s = client.latest();
  }
  return s;
}

TEST(StreamClientTls, StationGoesLiveOverTlsAndAnotherCaIsNamed) {
  testing::TestPki pki(std::filesystem::temp_directory_path() /
                       ("palp_stream_tls_" + std::to_string(::getpid())));
  const testing::Issued ca = pki.ca("lab-ca");
  const testing::Issued other = pki.ca("other-ca");
  const testing::Issued server = pki.issue("palpd.test", &ca, false, -3600, 86400, "IP:127.0.0.1");
  const testing::Issued station = pki.issue("station-9", &ca);
  const std::filesystem::path log = pki.dir() / "palpd.log";
  const int port = testing::start_palpd(
      "--scene phantom:sphere --device remote --port 0 --rate 1000 --no-realtime --duration 8"
      " --tls-cert " +
          server.cert_file + " --tls-key " + server.key_file + " --tls-client-ca " + ca.cert_file,
      log);
  ASSERT_GT(port, 0) << testing::read_text(log);

  StreamOptions o;
  o.port = static_cast<std::uint16_t>(port);
  o.volume_max_dim = 16;
  o.controller = true;
  o.tls_ca = ca.cert_file;
  o.tls_cert = station.cert_file;
  o.tls_key = station.key_file;
  StreamClient client(o);
  client.start();
  const LatestState live =
      wait_until(client, [](const LatestState& l) { return l.link.state == LinkState::Live; });
  EXPECT_EQ(live.link.state, LinkState::Live) << live.link.message;

  StreamOptions wrong = o;
  wrong.controller = false;
  wrong.tls_ca = other.cert_file;
  wrong.tls_cert.clear();
  wrong.tls_key.clear();
  StreamClient stranger(wrong);
  stranger.start();
  const LatestState refused = wait_until(stranger, [](const LatestState& l) {
    return l.link.message.find("wrong CA") != std::string::npos;
  });
  EXPECT_NE(refused.link.message.find("wrong CA"), std::string::npos) << refused.link.message;
  EXPECT_NE(refused.link.state, LinkState::Live);

  stranger.stop();
  client.stop();
  ASSERT_TRUE(testing::wait_palpd_exit(log)) << testing::read_text(log);
  EXPECT_NE(testing::read_text(log).find("[CN=station-9,O=palp test]"), std::string::npos)
      << testing::read_text(log);
  std::filesystem::remove_all(pki.dir());
}

}  // namespace
}  // namespace palp::view
