// palpd's DDS options (--dds [DOMAIN], --rig and the rest, also config file keys), kept out of
// palpd_main.cpp: their help, their names, the publisher they ask for, and the gate that lets a
// palp.v1 controller and DDS controllers hand device poses to palpd one at a time.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "cli_common/cli.hpp"
#include "interop/dds_publisher.hpp"
#include "net/control_target.hpp"
#include "net/server.hpp"

namespace palp::app {

extern const char* const kDdsOptionsHelp;
// `flags` and the DDS flags (dds, dds-control).
std::vector<std::string> with_dds_flags(std::vector<std::string> flags);
// `valued` and the DDS valued options (dds-domain, rig, dds-rate, ...).
std::vector<std::string> with_dds_options(std::vector<std::string> valued);

// The publisher's configuration asked for by `args` (nothing without --dds). UsageError for a
// value out of range, a DDS option without --dds, --dds-control without --token or with TLS
// (--tls-cert, --tls-client-ca: the token would travel in clear text on DDS).
std::unique_ptr<interop::DdsConfig> dds_config_from(const cli::Args& args, double loop_rate_hz);

// Forwards everything to palpd's ControlTarget; device poses one at a time (the palp.v1 io
// thread and the DDS thread may both hand them over: the remote device takes one writer).
class DdsControlGate : public net::ControlTarget {
 public:
  explicit DdsControlGate(net::ControlTarget& inner) : inner_(inner) {}
  std::string set_tool(const std::string& tool) override { return inner_.set_tool(tool); }
  std::string set_parameter(const std::string& name, double value) override {
    return inner_.set_parameter(name, value);
  }
  std::string set_paused(bool paused) override { return inner_.set_paused(paused); }
  std::string recentre() override { return inner_.recentre(); }
  std::string start_recording(const std::string& name, const std::string& by) override {
    return inner_.start_recording(name, by);
  }
  std::string stop_recording() override { return inner_.stop_recording(); }
  bool recording() const override { return inner_.recording(); }
  std::uint64_t record_lost() const override { return inner_.record_lost(); }
  bool set_device_pose(const Pose& pose, std::int64_t received_ns) override {
    const std::lock_guard lock(mutex_);
    return inner_.set_device_pose(pose, received_ns);
  }
  net::TaskSession* task() override { return inner_.task(); }

 private:
  net::ControlTarget& inner_;
  std::mutex mutex_;
};

// With --dds: the publisher (joined now, so a refused domain stops palpd before its loop
// starts), fed by `server`'s snapshot tap, started, and its topics printed unless `quiet`. The
// tap owns it: it lives as long as `server`. Nothing without --dds.
std::shared_ptr<interop::DdsPublisher> dds_beside(const cli::Args& args,
                                                  const net::SceneDescription& scene,
                                                  rt::HapticLoop& loop, net::ControlTarget& control,
                                                  net::Server& server, const std::string& tool,
                                                  bool quiet);

}  // namespace palp::app
