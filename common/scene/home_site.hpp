// Named places on a scene's skin where a device's workspace is centred (registration.hpp's home):
//   auto, anterior, posterior, left, right, superior, inferior
//                       the skin point --side finds from that side (auto: anterior first)
//   ribs-right, ribs-left
//                       the middle of the paper's ribs path on that side (palp traj ribs):
//                       the lateral chest wall over the lower ribs, 30 degrees anterior of lateral
//   X,Y,Z               a point in patient coordinates (the file's world, LPS mm), e.g. one read
//                       off 3D Slicer (which shows RAS: negate x and y)
// The home point is the skin point lifted `clearance_mm` along its outward normal, so the device
// at the centre of its workspace hovers above the skin.
#pragma once

#include <string>
#include <string_view>

#include "base/vec.hpp"
#include "model/field_sampler.hpp"

namespace palp {

struct HomeSite {
  std::string name;  // as given
  Vec3d skin{};      // scene mm
  Vec3d normal{};    // outward unit normal at the skin point
  Vec3d home{};      // skin + clearance · normal
};

// UsageError for an unknown name or malformed coordinates; InputError when no skin is found
// (a point given in coordinates is projected onto the skin along the outward normal).
HomeSite find_home_site(const FieldSampler& fields, std::string_view name, double clearance_mm);

}  // namespace palp
