// Volumes for tests that move a whole patient: the torso phantom on a coarse grid, and a volume
// turned 180 degrees about the body axis with its direction matrix kept (the table, behind a
// supine patient, then lies in front, as under a prone one); and the torso drawn with its truth.
#pragma once

#include <cstdint>

#include "base/volume.hpp"
#include "io/phantom.hpp"

namespace palp::testing {

// The torso's field of view at 3 x 3 x 4 mm: 160 x 107 x 48 voxels (table included).
inline CtVolume coarse_torso() {
  PhantomOptions o;
  o.dims = Index3{160, 107, 48};
  o.spacing = Vec3{3.0, 3.0, 4.0};
  return make_phantom("torso", o);
}

// The torso phantom with these options, and its truth masks.
struct DrawnTorso {
  CtVolume ct;
  PhantomTruth truth;
};

inline DrawnTorso torso_with(const PhantomOptions& o) {
  DrawnTorso d;
  d.ct = make_phantom("torso", o, &d.truth);
  return d;
}

// i and j reversed, the grid (and its direction matrix) kept.
template <class T>
Volume<T> turned_about_body_axis(const Volume<T>& v) {
  Volume<T> out(v.grid);
  const Index3& n = v.grid.dims;
  for (std::int64_t k = 0; k < n[2]; ++k)
    for (std::int64_t j = 0; j < n[1]; ++j)
      for (std::int64_t i = 0; i < n[0]; ++i) out.at(i, j, k) = v.at(n[0] - 1 - i, n[1] - 1 - j, k);
  return out;
}

}  // namespace palp::testing
