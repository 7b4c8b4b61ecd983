#include "interop/igtl_frame.hpp"

namespace palp::interop {

Matrix4 ras_from_scene(const Grid& grid) {
  const auto& d = grid.world.direction;  // row-major, columns are the i, j, k directions (LPS)
  const double flip[3] = {-1.0, -1.0, 1.0};
  Matrix4 m{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m[r][c] = flip[r] * d[static_cast<std::size_t>(3 * r + c)];
    m[r][3] = flip[r] * grid.world.origin[static_cast<std::size_t>(r)];
  }
  m[3] = {0.0, 0.0, 0.0, 1.0};
  return m;
}

Vec3d ras_vector(const Matrix4& m, const Vec3d& v) {
  return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
          m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
          m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}

Matrix4 ras_pose(const Matrix4& m, const Pose& pose) {
  const Vec3d axes[3] = {rotate(pose.orientation, Vec3d{1.0, 0.0, 0.0}),
                         rotate(pose.orientation, Vec3d{0.0, 1.0, 0.0}),
                         rotate(pose.orientation, Vec3d{0.0, 0.0, 1.0})};
  Matrix4 out{};
  for (int c = 0; c < 3; ++c) {
    const Vec3d a = ras_vector(m, axes[c]);
    out[0][c] = a.x, out[1][c] = a.y, out[2][c] = a.z;
  }
  const Vec3d p = ras_vector(m, pose.position);
  out[0][3] = p.x + m[0][3], out[1][3] = p.y + m[1][3], out[2][3] = p.z + m[2][3];
  out[3] = {0.0, 0.0, 0.0, 1.0};
  return out;
}

}  // namespace palp::interop
