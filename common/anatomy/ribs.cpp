// The ribs and the intercostal spaces (ribs.hpp).
#include "anatomy/ribs.hpp"

namespace palp::anatomy {

std::vector<RibTrace> find_ribs(const ScanContext&, const Spine&) {
  return {};
}

void rib_landmarks(const ScanContext&, const Spine&, const std::vector<RibTrace>&, Landmarks&) {}

}  // namespace palp::anatomy
