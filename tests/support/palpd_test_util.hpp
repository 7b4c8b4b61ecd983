// Helpers of the palpd tests: a tiny analytic scene and scripted devices.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "base/volume.hpp"
#include "devices/device.hpp"
#include "model/field_sampler.hpp"
#include "model/force_model.hpp"
#include "model/tool.hpp"

namespace palp::testing {

// A ball of radius 20 mm centred in a 32^3 grid of 2 mm voxels (centre (31, 31, 31) mm), with a
// bone ball of radius 8 mm inside it. Distances are exact Euclidean ones.
inline std::shared_ptr<const FieldSampler> ball_fields() {
  Grid grid;
  grid.dims = {32, 32, 32};
  grid.spacing = {2.0, 2.0, 2.0};
  DistanceMap surf(grid), bone(grid);
  for (std::int64_t k = 0; k < 32; ++k)
    for (std::int64_t j = 0; j < 32; ++j)
      for (std::int64_t i = 0; i < 32; ++i) {
        const double r = std::sqrt(std::pow(2.0 * i - 31, 2) + std::pow(2.0 * j - 31, 2) +
                                   std::pow(2.0 * k - 31, 2));
        surf.at(i, j, k) = static_cast<float>(20.0 - r);
        bone.at(i, j, k) = static_cast<float>(8.0 - r);
      }
  return std::make_shared<const FieldSampler>(std::move(surf), std::move(bone));
}

inline std::shared_ptr<const Model> ball_model(const char* tool = "finger:7") {
  return std::make_shared<const Model>(ball_fields(), parse_tool(tool));
}

// The pose pressing the pad `depth` mm into the top of the ball (tool +z up), shifted by `dx`.
inline Pose press_pose(double depth, double dx = 0.0) {
  Pose p;
  p.position = {31.0 + dx, 31.0, 31.0 + 20.0 - depth + 8.0};
  return p;
}

// A device that returns scripted statuses and poses and logs what it was written.
class ScriptedDevice final : public rt::Device {
 public:
  struct Step {
    rt::DeviceStatus status = rt::DeviceStatus::Ok;
    Pose pose{};
  };
  std::vector<Step> script;  // read n returns script[min(n, size-1)]
  std::vector<rt::DeviceCommand> writes;
  std::vector<int> write_after_read;  // for each write: the number of reads before it
  std::size_t reads = 0;

  std::string_view kind() const noexcept override { return "scripted"; }
  rt::DeviceStatus configure(const rt::DeviceConfig&) override { return rt::DeviceStatus::Ok; }
  rt::DeviceStatus activate() override { return rt::DeviceStatus::Ok; }
  rt::DeviceStatus read(std::int64_t, rt::DeviceSample& sample) noexcept override {
    const Step& s = script[std::min(reads, script.size() - 1)];
    ++reads;
    sample.pose = s.pose;
    sample.forced_fault = 0;
    return s.status;
  }
  rt::DeviceStatus write(const rt::DeviceCommand& command) noexcept override {
    // Tests reserve enough capacity; a real device would not allocate here.
    writes.push_back(command);
    write_after_read.push_back(static_cast<int>(reads));
    return rt::DeviceStatus::Ok;
  }
  rt::DeviceStatus deactivate() override { return rt::DeviceStatus::Ok; }
};

}  // namespace palp::testing
