// The camera's standard views in patient terms: see patient_view.hpp.
#include "render/patient_view.hpp"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace palp::view {

CameraPlacement patient_view(const PatientFrame& frame, Anatomy from, const Vec3d& centre,
                             double distance) {
  CameraPlacement c;
  c.focal = centre;
  c.position = centre + frame.toward(from) * distance;
  const bool axial = from == Anatomy::Superior || from == Anatomy::Inferior;
  c.up = axial ? frame.toward(Anatomy::Anterior) : frame.toward(Anatomy::Superior);
  return c;
}

std::string view_name(const PatientFrame& frame, const Vec3d& direction_of_projection) {
  const double n = norm(direction_of_projection);
  if (!(n > 0.0)) return "?";
  const Vec3d from = direction_of_projection * (-1.0 / n);  // from the focal point to the eye
  std::vector<std::pair<double, Anatomy>> cosines;
  for (Anatomy a : {Anatomy::Anterior, Anatomy::Posterior, Anatomy::Left, Anatomy::Right,
                    Anatomy::Superior, Anatomy::Inferior})
    cosines.emplace_back(dot(from, frame.toward(a)), a);
  std::sort(cosines.begin(), cosines.end(),
            [](const auto& x, const auto& y) { return x.first > y.first; });
  if (cosines[0].first >= std::cos(10.0 * 3.14159265358979323846 / 180.0))
    return to_string(cosines[0].second);
  return std::string(to_string(cosines[0].second)) + "-" + to_string(cosines[1].second);
}

}  // namespace palp::view
