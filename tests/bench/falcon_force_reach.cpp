// The force a Novint Falcon can render across its workspace with palp's effort cap
// (falcon::kMaxEffort, 4095 a motor; docs/devices.md): for a position p the efforts are linear in
// the force, e = M(p) F with M = -kEffortPerNmm x J_p^T (N -> counts), so along a unit direction d
// the largest force is cap / max_i |M_i . d| and the largest force in every direction (the worst
// direction) is cap / max_i |M_i|.
//
//   falcon_force_reach OUT.csv
//
// writes one row per millimetre along the three axes through the workspace centre (offset -40 ..
// +40 mm): axis, offset_mm, worst_N (the largest force renderable in every direction), x_N, y_N,
// z_N (along +-x, +-y, +-z; the map is linear, so both signs alike; +y is the skin pushing a finger
// back with palpd's placement), and prints a summary over the 9 x 9 x 9 grid of the +-40 mm cube
// (the kinematics tests' grid). Charted by tests/bench/falcon_force_reach.sh. It measures; it is
// not a test.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "devices/falcon_kinematics.hpp"

namespace {

using palp::Vec3d;
namespace falcon = palp::falcon;

struct Reach {
  double worst = 0, x = 0, y = 0, z = 0;
};

// False where the position is outside the reach or singular.
bool reach_at(const Vec3d& p, Reach& r) {
  Vec3d rows[3];  // M's rows: counts per N
  const Vec3d unit[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int j = 0; j < 3; ++j) {
    Vec3d tau;
    if (!falcon::joint_torques(p, unit[j], tau)) return false;
    const Vec3d col = tau * -falcon::kEffortPerNmm;
    (j == 0 ? rows[0].x : j == 1 ? rows[0].y : rows[0].z) = col.x;
    (j == 0 ? rows[1].x : j == 1 ? rows[1].y : rows[1].z) = col.y;
    (j == 0 ? rows[2].x : j == 1 ? rows[2].y : rows[2].z) = col.z;
  }
  const double cap = falcon::kMaxEffort;
  const auto along = [&](const Vec3d& d) {
    double largest = 0;
    for (const Vec3d& row : rows) largest = std::max(largest, std::abs(palp::dot(row, d)));
    return cap / largest;
  };
  double largest_row = 0;
  for (const Vec3d& row : rows) largest_row = std::max(largest_row, palp::norm(row));
  r.worst = cap / largest_row;
  r.x = along({1, 0, 0});
  r.y = along({0, 1, 0});
  r.z = along({0, 0, 1});
  return true;
}

void summary() {
  std::vector<double> worst, up;
  int unreachable = 0;
  for (int i = -4; i <= 4; ++i)
    for (int j = -4; j <= 4; ++j)
      for (int k = -4; k <= 4; ++k) {
        Reach r;
        if (!reach_at(falcon::kWorkspaceCentre + Vec3d{10.0 * i, 10.0 * j, 10.0 * k}, r)) {
          ++unreachable;
          continue;
        }
        worst.push_back(r.worst);
        up.push_back(r.y);
      }
  std::sort(worst.begin(), worst.end());
  std::sort(up.begin(), up.end());
  const auto share = [](const std::vector<double>& v, double n) {
    return 100.0 * double(std::count_if(v.begin(), v.end(), [&](double x) { return x >= n; })) /
           double(v.size());
  };
  Reach centre;
  reach_at(falcon::kWorkspaceCentre, centre);
  std::printf(
      "cap %d counts a motor. centre: %.2f N in every direction, %.2f N along x, %.2f N along y "
      "(up / down), %.2f N along z (out / in)\n",
      falcon::kMaxEffort, centre.worst, centre.x, centre.y, centre.z);
  std::printf(
      "9x9x9 grid over +-40 mm (%zu points, %d unreachable): every direction min %.2f N, median "
      "%.2f N, max %.2f N; 8 N in every direction at %.0f %% of the points, 5 N at %.0f %%; along "
      "y min %.2f N, 8 N along y at %.0f %%\n",
      worst.size(), unreachable, worst.front(), worst[worst.size() / 2], worst.back(),
      share(worst, 8.0), share(worst, 5.0), up.front(), share(up, 8.0));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: falcon_force_reach OUT.csv\n");
    return 2;
  }
  std::FILE* f = std::fopen(argv[1], "w");
  if (!f) {
    std::perror(argv[1]);
    return 1;
  }
  std::fprintf(f, "axis,offset_mm,worst_N,x_N,y_N,z_N\n");
  const char* names[] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis)
    for (int o = -40; o <= 40; ++o) {
      Vec3d p = falcon::kWorkspaceCentre;
      (axis == 0 ? p.x : axis == 1 ? p.y : p.z) += o;
      Reach r;
      if (reach_at(p, r))
        std::fprintf(f, "%s,%d,%.4f,%.4f,%.4f,%.4f\n", names[axis], o, r.worst, r.x, r.y, r.z);
    }
  std::fclose(f);
  summary();
  return 0;
}
