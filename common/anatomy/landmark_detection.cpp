// find_landmarks (landmark_detection.hpp): the scan in the patient's axes, then the spine, the
// ribs (which check and, without a sacrum, anchor the count), the pelvis, and the skin points.
#include "anatomy/landmark_detection.hpp"

#include <algorithm>
#include <cmath>

#include "anatomy/landmark_context.hpp"
#include "anatomy/pelvis.hpp"
#include "anatomy/ribs.hpp"
#include "anatomy/skeleton_labels.hpp"
#include "anatomy/spine_levels.hpp"
#include "base/errors.hpp"

namespace palp::anatomy {

std::optional<SkinPoint> skin_along(const ScanContext& scan, const Vec3d& world, const Vec3d& dir) {
  constexpr double kReachMm = 300.0;
  auto point = scan.skin.project(world, dir, kReachMm);
  // From outside the body, a march away from it never meets the skin: the skin lies behind.
  if (point && scan.skin.distance(world) <= 0.0 && scan.skin.distance(*point + dir) <= 0.0)
    point.reset();
  if (!point && scan.skin.distance(world) <= 0.0) point = scan.skin.project(world, -dir, kReachMm);
  if (!point) return std::nullopt;
  const auto normal = scan.skin.outward_normal(*point);
  if (!normal) return std::nullopt;
  return SkinPoint{*point, *normal};
}

namespace {

ScanContext make_context(const LandmarkInputs& in) {
  ScanContext scan;
  scan.bone = to_patient_order(in.bone);
  scan.body = to_patient_order_like(in.body, scan.bone);
  scan.bodies = slice_bodies(scan.body);
  scan.skin = SkinMap(in.d_surf);
  if (!in.artery.data.empty()) {
    scan.artery = to_patient_order_like(in.artery, scan.bone);
    scan.artery_source = in.artery_source;
  }
  if (!in.skeleton_labels.data.empty() && !in.skeleton_names.empty()) {
    scan.skeleton = to_patient_order_like(in.skeleton_labels, scan.bone, true);
    scan.skeleton_names = in.skeleton_names;
  }
  return scan;
}

// The column's median x, or the body's where there is no column.
double midline(const ScanContext& scan, const Spine& spine) {
  std::vector<double> xs;
  for (const ColumnSlice& c : spine.column)
    if (c.on_column) xs.push_back(c.x);
  if (xs.empty())
    for (const SliceBody& b : scan.bodies)
      if (b.voxels) xs.push_back(b.cx);
  if (xs.empty()) return 0.5 * static_cast<double>(scan.bone.dims[0] - 1);
  std::nth_element(xs.begin(), xs.begin() + static_cast<std::ptrdiff_t>(xs.size() / 2), xs.end());
  return xs[xs.size() / 2];
}

void add_vertebrae(const ScanContext& scan, const Spine& spine, Landmarks& out) {
  for (const VertebraSegment& seg : spine.segments) {
    Vertebra v;
    v.name = seg.name;
    v.body_centre = scan.bone.world(seg.centre);
    if (seg.spinous_tip) v.spinous_tip = scan.bone.world(*seg.spinous_tip);
    // Named: the count's confidence; unnamed: the body's own (its discs' clarity), halved.
    v.confidence = seg.name ? seg.confidence : 0.5 * seg.gap_clarity;
    v.reason = seg.reason;
    if (!seg.spinous_tip && !seg.sacrum)
      v.reason += std::string(v.reason.empty() ? "" : "; ") +
                  "no spinous process apart from its neighbours' along the posterior midline";
    out.vertebrae.push_back(v);
  }
}

// The most posterior bone on the midline at the sacrum's top (its first spinous tubercle), for
// the L5/S1 interspace.
std::optional<Vec3d> sacral_crest_top(const ScanContext& scan, const Spine& spine) {
  if (spine.sacrum < 0) return std::nullopt;
  const VertebraSegment& s = spine.segments[static_cast<std::size_t>(spine.sacrum)];
  const PatientMask& b = scan.bone;
  const double from = s.z_hi - 15.0 / b.spacing[2];
  const auto half = std::max<std::int64_t>(1, std::lround(6.0 / b.spacing[0]));
  std::optional<Vec3d> best;
  for (auto z = static_cast<std::int64_t>(std::ceil(from)); z <= static_cast<std::int64_t>(s.z_hi);
       ++z) {
    if (z < 0 || z >= b.dims[2]) continue;
    const ColumnSlice& c = spine.column[static_cast<std::size_t>(z)];
    for (std::int64_t x = std::lround(c.x) - half; x <= std::lround(c.x) + half; ++x)
      for (std::int64_t y = b.dims[1] - 1; y > std::lround(c.y); --y)
        if (b.at(x, y, z)) {
          if (!best || static_cast<double>(y) + 0.5 > best->y)
            best =
                Vec3d{static_cast<double>(x), static_cast<double>(y) + 0.5, static_cast<double>(z)};
          break;
        }
  }
  return best;
}

void add_interspaces(const ScanContext& scan, const Spine& spine, Landmarks& out) {
  const char* names[] = {"L1", "L2", "L3", "L4", "L5", "S"};
  const auto find = [&](const std::string& name) -> const VertebraSegment* {
    for (const VertebraSegment& s : spine.segments)
      if (s.name && *s.name == name) return &s;
    return nullptr;
  };
  for (int i = 0; i < 5; ++i) {
    LumbarInterspace li;
    li.name = std::string(names[i]) + "/" + (i == 4 ? "S1" : names[i + 1]);
    const VertebraSegment* upper = find(names[i]);
    const VertebraSegment* lower = find(names[i + 1]);
    std::optional<Vec3d> lower_tip = lower ? lower->spinous_tip : std::nullopt;
    if (lower && lower->sacrum) lower_tip = sacral_crest_top(scan, spine);
    if (!upper || !lower) {
      li.reason =
          std::string(upper ? names[i + 1] : names[i]) + " is not found and numbered in the scan";
    } else if (!upper->spinous_tip || !lower_tip) {
      li.reason =
          std::string("no spinous tip of ") + (upper->spinous_tip ? names[i + 1] : names[i]);
    } else {
      const Vec3d mid = scan.bone.world((*upper->spinous_tip + *lower_tip) * 0.5);
      const auto skin = skin_along(scan, mid, {0.0, 1.0, 0.0});
      if (!skin) {
        li.reason = "no skin behind the spinous processes in the scan";
      } else {
        li.skin_point = skin->point, li.normal = skin->normal;
        li.confidence = std::min(upper->confidence, lower->confidence);
      }
    }
    out.lumbar_interspaces.push_back(li);
  }
}

void add_pelvis(const ScanContext& scan, const Spine& spine, const Pelvis& pelvis, Landmarks& out) {
  double z_sum = 0.0, index_z = 0.0, confidence = 1.0;
  int tops = 0;
  for (int s = 0; s < 2; ++s) {
    IliacCrest crest;
    crest.side = side_of(s);
    const auto& top = pelvis.crest_top[static_cast<std::size_t>(s)];
    crest.reason = pelvis.reason[static_cast<std::size_t>(s)];
    if (top) {
      crest.top = scan.bone.world(*top);
      crest.confidence = pelvis.confidence[static_cast<std::size_t>(s)];
      z_sum += crest.top->z, index_z += top->z, ++tops;
      confidence = std::min(confidence, crest.confidence);
    }
    out.iliac_crests.push_back(crest);
  }
  TuffierLine& t = out.tuffier_line;
  if (tops == 0) {
    t.reason = "no iliac crest in the scan";
    return;
  }
  t.z_mm = z_sum / tops;
  index_z /= tops;
  t.confidence = tops == 2 ? confidence : 0.5 * confidence;
  if (tops == 1) t.reason = "one crest only: its own level";
  const int s = segment_at(spine, index_z);
  if (s < 0 || !spine.segments[static_cast<std::size_t>(s)].name) {
    t.reason += std::string(t.reason.empty() ? "" : "; ") + "no numbered vertebra at its level";
    return;
  }
  const VertebraSegment& seg = spine.segments[static_cast<std::size_t>(s)];
  const double h = seg.z_hi - seg.z_lo;
  // Within a sixth of a vertebra of a disc: the disc's level ("L4/L5").
  std::string level = *seg.name;
  if (index_z - seg.z_lo < h / 6.0 && s > 0 && spine.segments[static_cast<std::size_t>(s - 1)].name)
    level = *spine.segments[static_cast<std::size_t>(s - 1)].name + "/" + *seg.name;
  else if (seg.z_hi - index_z < h / 6.0 && s + 1 < static_cast<int>(spine.segments.size()) &&
           spine.segments[static_cast<std::size_t>(s + 1)].name)
    level = *seg.name + "/" + *spine.segments[static_cast<std::size_t>(s + 1)].name;
  if (level == "L5/S") level = "L5/S1";
  t.vertebral_level = level;
  t.confidence = std::min(t.confidence, seg.confidence);
}

// The lowest vertebra a rib's head lies at. Without a sacrum it is T12 only when the scan shows
// a vertebra below it without ribs (else a thin slab's lowest rib may be any rib).
std::optional<int> lowest_rib_vertebra(const std::vector<RibTrace>& ribs, const Spine& spine) {
  std::optional<int> lowest;
  for (const RibTrace& r : ribs)
    if (r.vertebra >= 0 && (!lowest || r.vertebra < *lowest)) lowest = r.vertebra;
  if (lowest && spine.sacrum < 0 && *lowest == 0) {
    return std::nullopt;
  }
  return lowest;
}

}  // namespace

Landmarks find_landmarks(const LandmarkInputs& inputs, const LandmarkProgress& progress) {
  const auto step = [&](const char* name) {
    if (progress) progress(name);
  };
  if (inputs.bone.data.empty() || inputs.body.data.empty() || inputs.d_surf.data.empty())
    throw InputError("landmarks need the bone and body masks and the skin's distance map");
  Landmarks out;
  out.scene = inputs.scene;
  step("patient axes");
  ScanContext scan = make_context(inputs);
  step("spine");
  Spine spine = find_spine(scan.bone, scan.bodies);
  scan.midline_x = midline(scan, spine);
  step("ribs");
  std::vector<RibTrace> ribs = find_ribs(scan, spine);
  name_vertebrae(spine, lowest_rib_vertebra(ribs, spine));
  // Labelled vertebrae and ribs (prep --labels) name themselves (skeleton_labels.hpp).
  label_vertebrae(scan, spine);
  label_ribs(scan, ribs);
  add_vertebrae(scan, spine, out);
  rib_landmarks(scan, spine, ribs, out);
  step("pelvis");
  const Pelvis pelvis = find_pelvis(scan, spine);
  add_pelvis(scan, spine, pelvis, out);
  step("skin points");
  add_interspaces(scan, spine, out);
  out.femoral_pulse_points = femoral_pulse_points(scan, pelvis);
  out.notes.insert(out.notes.end(), spine.notes.begin(), spine.notes.end());
  if (spine.sacrum < 0) out.notes.push_back("No sacrum found: " + spine.sacrum_reason + ".");
  if (!scan.artery)
    out.notes.push_back(
        "The scan shows no artery: the femoral pulse points are the mid-inguinal "
        "points from the bones.");
  return out;
}

}  // namespace palp::anatomy
