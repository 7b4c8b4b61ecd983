#include "base/volume.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>

#include "base/errors.hpp"

namespace palp {

double Grid::min_spacing() const {
  return std::min({spacing[0], spacing[1], spacing[2]});
}

double Grid::max_spacing() const {
  return std::max({spacing[0], spacing[1], spacing[2]});
}

Vec3 Grid::extent_mm() const {
  return {static_cast<double>(dims[0] - 1) * spacing[0],
          static_cast<double>(dims[1] - 1) * spacing[1],
          static_cast<double>(dims[2] - 1) * spacing[2]};
}

void validate_grid(const Grid& grid, const std::string& what) {
  for (int a = 0; a < 3; ++a) {
    if (grid.dims[a] <= 0 || grid.dims[a] > kMaxVoxelsPerAxis) {
      std::ostringstream msg;
      msg << what << ": dimensions " << grid.dims[0] << "x" << grid.dims[1] << "x" << grid.dims[2]
          << " are not usable (each must be 1.." << kMaxVoxelsPerAxis << ")";
      throw InputError(msg.str());
    }
    if (!std::isfinite(grid.spacing[a]) || grid.spacing[a] < kMinSpacingMm ||
        grid.spacing[a] > kMaxSpacingMm) {
      std::ostringstream msg;
      msg << what << ": spacing " << grid.spacing[0] << " x " << grid.spacing[1] << " x "
          << grid.spacing[2] << " mm is not usable (each must be in [" << kMinSpacingMm << ", "
          << kMaxSpacingMm << "] mm)";
      throw InputError(msg.str());
    }
  }
}

std::size_t available_memory_bytes() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  std::size_t value = 0;
  std::string unit;
  while (meminfo >> key >> value >> unit) {
    if (key == "MemAvailable:") return value * 1024;
  }
  return 0;
}

std::size_t peak_rss_bytes() {
  // VmHWM belongs to this process's address space. getrusage's ru_maxrss would not do: Linux
  // carries it across fork and execve, so a child of a large process reports the parent's peak.
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmHWM:") {
      std::size_t kib = 0;
      status >> kib;
      return kib * 1024;
    }
    status.ignore(std::numeric_limits<std::streamsize>::max(), '\n');
  }
  return 0;
}

void check_allocation(const Grid& grid, std::size_t bytes_per_voxel, const std::string& what) {
  validate_grid(grid, what);
  const double bytes =
      static_cast<double>(grid.voxel_count()) * static_cast<double>(bytes_per_voxel);
  const std::size_t available = available_memory_bytes();
  if (available != 0 && bytes > static_cast<double>(available)) {
    char msg[512];
    std::snprintf(
        msg, sizeof msg,
        "%s: %lldx%lldx%lld voxels need %.1f MiB but only %.1f MiB of memory is available",
        what.c_str(), static_cast<long long>(grid.dims[0]), static_cast<long long>(grid.dims[1]),
        static_cast<long long>(grid.dims[2]), bytes / 1048576.0,
        static_cast<double>(available) / 1048576.0);
    throw ResourceError(msg);
  }
}

}  // namespace palp
