// palpd's loop and server around a device on the ball scene, with one observer already joined:
// what the device tests use to check what clients are told about the device.
#pragma once

#include <optional>
#include <string>
#include <utility>

#include "devices/device.hpp"
#include "loop/haptic_loop.hpp"
#include "net/server.hpp"
#include "support/net_test_client.hpp"
#include "support/palpd_test_util.hpp"

namespace palp::testing {

// The ball scene (ball_model) served by a started haptic loop and server (ephemeral port, Stats
// every 0.2 s) driving `device`, and an observer client that has said hello. Call stop() before
// deactivating the device; the destructor stops what is still running.
class ServedBall {
 public:
  ServedBall(rt::Device& device, const rt::LoopConfig& loop_config, std::string device_name,
             std::optional<net::SceneDescription::Placement> placement = std::nullopt)
      : model_(ball_model()),
        loop_(model_, device, loop_config),
        server_(server_config(), scene(std::move(device_name), std::move(placement)), loop_,
                nullptr) {
    loop_.start();
    server_.start();
    client_.emplace(server_.port());
    client_->hello(v1::OBSERVER, "", net::kProtocolVersion, 0, 200.0);
  }
  ~ServedBall() { stop(); }
  ServedBall(const ServedBall&) = delete;
  ServedBall& operator=(const ServedBall&) = delete;

  void stop() {
    client_.reset();
    server_.stop();
    loop_.stop();
  }
  TestClient& client() { return *client_; }
  rt::HapticLoop& loop() { return loop_; }

 private:
  static net::ServerConfig server_config() {
    net::ServerConfig config;
    config.port = 0;
    config.stats_interval_s = 0.2;
    return config;
  }
  net::SceneDescription scene(std::string device_name,
                              std::optional<net::SceneDescription::Placement> placement) const {
    net::SceneDescription scene;
    scene.source = "ball";
    scene.grid = model_->fields().grid();
    scene.device = std::move(device_name);
    scene.placement = std::move(placement);
    return scene;
  }

  std::shared_ptr<const Model> model_;
  rt::HapticLoop loop_;
  net::Server server_;
  std::optional<TestClient> client_;
};

}  // namespace palp::testing
