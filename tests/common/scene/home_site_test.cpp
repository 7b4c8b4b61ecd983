// Home sites: named sides and the ribs site lie on the skin with outward normals, the home point
// is lifted by the clearance, a point in patient coordinates is projected onto the skin.
#include "scene/home_site.hpp"

#include <gtest/gtest.h>

#include "base/errors.hpp"
#include "io/phantom.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/segment/segmentation.hpp"

namespace palp {
namespace {

const FieldSampler& torso_fields() {
  static const FieldSampler fields = [] {
    PhantomOptions o;
    o.dims = Index3{128, 86, 32};
    o.spacing = Vec3{3.75, 3.75, 6.0};
    const CtVolume ct = make_phantom("torso", o);
    const Mask body = segment_body(ct, {});
    return FieldSampler(signed_distance(body));
  }();
  return fields;
}

TEST(HomeSite, AnteriorIsOnTheFrontSkinLiftedByTheClearance) {
  const FieldSampler& f = torso_fields();
  const HomeSite site = find_home_site(f, "auto", 20.0);
  EXPECT_NEAR(f.sample_surf(site.skin).value, 0.0, 0.05);
  EXPECT_LT(site.normal.y, -0.9);  // LPS storage: anterior is -y
  EXPECT_NEAR(norm(site.home - site.skin), 20.0, 1e-9);
  EXPECT_LT(f.sample_surf(site.home).value, -19.0);  // in air above the skin
  const HomeSite anterior = find_home_site(f, "anterior", 20.0);
  EXPECT_EQ(anterior.skin, site.skin);
}

TEST(HomeSite, RibsRightIsOnThePatientsRightFlank) {
  const FieldSampler& f = torso_fields();
  const HomeSite site = find_home_site(f, "ribs-right", 10.0);
  EXPECT_NEAR(f.sample_surf(site.skin).value, 0.0, 0.5);
  EXPECT_LT(site.normal.x, -0.5);  // toward the patient's right (-x in LPS)
}

TEST(HomeSite, PatientCoordinatesAreProjectedOntoTheSkin) {
  const FieldSampler& f = torso_fields();
  const HomeSite front = find_home_site(f, "anterior", 0.0);
  // The same point in patient (LPS world) coordinates, 5 mm out in the air.
  const Grid& g = f.grid();
  const Vec3d out = front.skin + front.normal * 5.0;
  const Vec3d world = to_vec3d(g.world.origin) + out;  // identity direction
  const std::string text =
      std::to_string(world.x) + "," + std::to_string(world.y) + "," + std::to_string(world.z);
  const HomeSite site = find_home_site(f, text, 0.0);
  EXPECT_LT(norm(site.skin - front.skin), 1.0);
}

TEST(HomeSite, UnknownNamesAreUsageErrors) {
  EXPECT_THROW(find_home_site(torso_fields(), "belly", 20.0), UsageError);
  EXPECT_THROW(find_home_site(torso_fields(), "1,2", 20.0), UsageError);
  EXPECT_THROW(find_home_site(torso_fields(), "auto", -1.0), UsageError);
}

}  // namespace
}  // namespace palp
