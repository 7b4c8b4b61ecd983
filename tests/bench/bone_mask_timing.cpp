// The bone mask's cost with and without the marrow-between-cortices step (issue 13: prep time at
// most +5 %), on the torso phantom at a given grid, runs alternating so load drifts hit both; the
// minimum of each is the figure to compare. Also prints the torso bone Dice of each against the
// phantom's truth. It measures; it is not a test.
//
// Usage: bone_mask_timing [runs=5] [nx ny nz sx sy sz] [step]   (default 384 384 160 0.8 0.8 1.5)
// step: the step the second variant leaves out, "enclosure" (default), "notches" (the notch
// fill after the edge trim), "calculi" (compact detached islands removed), "lumens" (thick
// contrast lumens resting on the cortex removed), "ribs" (ribs without a seed kept) or "skin" (the
// skin clearance); it also prints how many voxels only the full mask holds and how many of them
// the phantom's truth calls bone.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "io/phantom.hpp"
#include "prep/segment/hu_levels.hpp"
#include "prep/segment/segmentation.hpp"

int main(int argc, char** argv) {
  using namespace palp;
  const int runs = argc > 1 ? std::atoi(argv[1]) : 5;
  PhantomOptions options;
  options.dims = Index3{384, 384, 160};
  options.spacing = Vec3{0.8, 0.8, 1.5};
  if (argc > 7) {
    options.dims = Index3{std::atoll(argv[2]), std::atoll(argv[3]), std::atoll(argv[4])};
    options.spacing = Vec3{std::atof(argv[5]), std::atof(argv[6]), std::atof(argv[7])};
  }
  PhantomTruth truth;
  const CtVolume ct = make_phantom("torso", options, &truth);
  SegmentationParams with;
  const Mask body = segment_body(ct, with);
  const HuLevels levels = estimate_hu_levels(ct, body);
  with.bone_seed_hu = levels.levels.seed_hu;
  with.bone_grow_hu = levels.levels.grow_hu;
  const std::string step = argc > 8 ? argv[8] : "enclosure";
  SegmentationParams without = with;
  if (step == "notches") {
    without.bone_notch_faces = 0;
  } else if (step == "calculi") {
    without.bone_calculus_max_length_mm = 0.0;
  } else if (step == "lumens") {
    without.bone_lumen_radius_mm = 0.0;
  } else if (step == "ribs") {
    without.bone_rib_depth_mm = 0.0;
  } else if (step == "skin") {
    without.bone_skin_clearance_mm = 0.0;
  } else if (step == "enclosure") {
    without.bone_enclosure_directions = 0;
  } else {
    std::fprintf(
        stderr,
        "bone_mask_timing: step must be enclosure, notches, calculi, lumens, ribs or skin\n");
    return 2;
  }
  std::vector<double> t_with, t_without, cpu_with, cpu_without;
  Mask bone_with, bone_without;
  for (int r = 0; r < runs; ++r)
    for (int variant = 0; variant < 2; ++variant) {
      const auto t0 = std::chrono::steady_clock::now();
      const std::clock_t c0 = std::clock();
      Mask bone = segment_bone(ct, body, variant == 0 ? with : without);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      (variant == 0 ? t_with : t_without).push_back(s);
      (variant == 0 ? cpu_with : cpu_without)
          .push_back(static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
      (variant == 0 ? bone_with : bone_without) = std::move(bone);
    }
  const auto dice = [&](const Mask& m) {
    std::int64_t both = 0, a = 0, b = 0;
    for (std::size_t n = 0; n < m.size(); ++n)
      both += m.data[n] && truth.bone.data[n], a += m.data[n] != 0, b += truth.bone.data[n] != 0;
    return 2.0 * static_cast<double>(both) / static_cast<double>(a + b);
  };
  std::sort(t_with.begin(), t_with.end());
  std::sort(t_without.begin(), t_without.end());
  std::sort(cpu_with.begin(), cpu_with.end());
  std::sort(cpu_without.begin(), cpu_without.end());
  std::printf("torso %lldx%lldx%lld at %.2fx%.2fx%.2f mm, %d runs alternating\n",
              static_cast<long long>(ct.grid.dims[0]), static_cast<long long>(ct.grid.dims[1]),
              static_cast<long long>(ct.grid.dims[2]), ct.grid.spacing[0], ct.grid.spacing[1],
              ct.grid.spacing[2], runs);
  // CPU time (all threads) is less sensitive to other processes' load than the wall clock.
  std::printf(
      "bone mask with %s:    wall min %.3f s, median %.3f s; CPU median %.3f s; bone Dice "
      "%.4f\n",
      step.c_str(), t_with.front(), t_with[t_with.size() / 2], cpu_with[cpu_with.size() / 2],
      dice(bone_with));
  std::printf(
      "bone mask without %s: wall min %.3f s, median %.3f s; CPU median %.3f s; bone Dice "
      "%.4f\n",
      step.c_str(), t_without.front(), t_without[t_without.size() / 2],
      cpu_without[cpu_without.size() / 2], dice(bone_without));
  std::int64_t only_with = 0, only_with_truth = 0, only_without = 0, only_without_truth = 0;
  for (std::size_t n = 0; n < bone_with.size(); ++n) {
    const bool added = bone_with.data[n] && !bone_without.data[n];
    const bool removed = !bone_with.data[n] && bone_without.data[n];
    only_with += added;
    only_with_truth += added && truth.bone.data[n];
    only_without += removed;
    only_without_truth += removed && truth.bone.data[n];
  }
  std::printf("voxels only with %s: %lld, of them bone in the truth %lld\n", step.c_str(),
              static_cast<long long>(only_with), static_cast<long long>(only_with_truth));
  std::printf("voxels only without %s: %lld, of them bone in the truth %lld\n", step.c_str(),
              static_cast<long long>(only_without), static_cast<long long>(only_without_truth));
  return 0;
}
