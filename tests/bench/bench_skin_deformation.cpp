// Google Benchmark of the skin deformation update (common/deform/skin_deformation.cpp) at the size
// the palpview issue sets: a 512x512x400 CT decimated to 256x256x200 at 1.6 x 1.6 x 2 mm, pressed
// by a finger pad of 1, 7, 19 or 37 contacts (pad radius 7.5 mm for 37) to 3, 6 or 10 mm, sliding
// 0.8 mm between frames so every update also restores what the previous one wrote. Measures
// only; never part of CTest.
//
// Data flow: synthetic body (elliptic cylinder along k, -1000 HU outside, soft tissue inside) ->
// SkinDeformer over it -> per iteration: the pad's proxies on the anterior skin (y = y_skin),
// contact points `depth` mm deeper with a small per-point friction drag -> update() into the
// render buffer. Counters: ChainMail elements in the ROI, voxels in the written box.
// BM_SkinDeformFull runs the 512 x 512 x 400 CT at full resolution; BM_SkinDeformPalpview the
// press palpview records there (--stats-json deformation_split: float32 spacing, oblique flank
// press, sliding proxies), so the benchmark measures what palpview does.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "deform/skin_deformation.hpp"
#include "model/tool.hpp"

namespace {

constexpr std::array<std::int64_t, 3> kDims{256, 256, 200};
constexpr std::array<double, 3> kSpacing{1.6, 1.6, 2.0};
constexpr double kCentreX = 204.8, kCentreY = 204.8, kSemiX = 180.0, kSemiY = 130.0;

// The elliptic body (soft tissue with a sine texture, `wave_i` and `wave_k` radians a voxel) in
// air on a grid of `dims` at `spacing`.
std::vector<float> ellipse_body(const std::array<std::int64_t, 3>& dims,
                                const std::array<double, 3>& spacing, double wave_i,
                                double wave_k) {
  std::vector<float> v(static_cast<std::size_t>(dims[0] * dims[1] * dims[2]));
  for (std::int64_t k = 0; k < dims[2]; ++k)
    for (std::int64_t j = 0; j < dims[1]; ++j)
      for (std::int64_t i = 0; i < dims[0]; ++i) {
        const double x = (i * spacing[0] - kCentreX) / kSemiX;
        const double y = (j * spacing[1] - kCentreY) / kSemiY;
        v[i + dims[0] * (j + dims[1] * k)] =
            x * x + y * y < 1.0
                ? static_cast<float>(40.0 + 20.0 * std::sin(wave_i * i + wave_k * k))
                : -1000.0f;
      }
  return v;
}

std::vector<float> body_volume() {
  return ellipse_body(kDims, kSpacing, 0.3, 0.2);
}

// Contacts of a finger:n pad pressed along +y into the anterior skin at (cx, y_skin, cz).
std::vector<palp::DeformContact> press(int n, double cx, double cz, double depth) {
  const double y_skin = kCentreY - kSemiY;
  std::vector<palp::DeformContact> contacts;
  const auto points = palp::finger_pad_points(n, 0.0);
  for (std::size_t m = 0; m < points.size(); ++m) {
    const palp::Vec3d p{cx + points[m].x, y_skin, cz + points[m].y};
    const palp::Vec3d drag{0.3 * std::cos(0.7 * m), 0.0, 0.3 * std::sin(0.7 * m)};
    contacts.push_back({p + palp::Vec3d{0.0, depth, 0.0} + drag, p});
  }
  return contacts;
}

void BM_SkinDeformUpdate(benchmark::State& state) {
  static const std::vector<float> original = body_volume();
  const int contacts_per_pad = static_cast<int>(state.range(0));
  const double depth = static_cast<double>(state.range(1));
  palp::SkinDeformer deformer(kDims, kSpacing, original);
  std::vector<float> out = original;
  const std::vector<palp::DeformContact> frames[2] = {press(contacts_per_pad, 204.8, 200.0, depth),
                                                      press(contacts_per_pad, 205.6, 200.0, depth)};
  palp::DeformResult last;
  std::int64_t frame = 0;
  for (int warm = 0; warm < 4; ++warm) last = deformer.update(frames[warm % 2], out);
  for (auto _ : state) {
    last = deformer.update(frames[frame++ % 2], out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["roi_elements"] = static_cast<double>(last.elements);
  state.counters["written_voxels"] = static_cast<double>(
      (last.hi[0] - last.lo[0]) * (last.hi[1] - last.lo[1]) * (last.hi[2] - last.lo[2]));
}
BENCHMARK(BM_SkinDeformUpdate)
    ->ArgsProduct({{1, 7, 19, 37}, {3, 6, 10}})
    ->ArgNames({"contacts", "depth_mm"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The same, with a smaller and a larger ROI margin (the propagation box does not depend on it;
// only the ChainMail box's reset does).
void BM_SkinDeformMargin(benchmark::State& state) {
  static const std::vector<float> original = body_volume();
  palp::DeformerParams params;
  params.roi_margin_mm = static_cast<double>(state.range(0));
  palp::SkinDeformer deformer(kDims, kSpacing, original, params);
  std::vector<float> out = original;
  const std::vector<palp::DeformContact> frames[2] = {press(37, 204.8, 200.0, 6.0),
                                                      press(37, 205.6, 200.0, 6.0)};
  palp::DeformResult last;
  std::int64_t frame = 0;
  for (int warm = 0; warm < 4; ++warm) last = deformer.update(frames[warm % 2], out);
  for (auto _ : state) {
    last = deformer.update(frames[frame++ % 2], out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["roi_elements"] = static_cast<double>(last.elements);
}
BENCHMARK(BM_SkinDeformMargin)
    ->Arg(10)
    ->Arg(20)
    ->Arg(40)
    ->ArgNames({"margin_mm"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The 512 x 512 x 400 CT at 0.8 x 0.8 x 1 mm: the same body.
constexpr std::array<std::int64_t, 3> kFullDims{512, 512, 400};
std::vector<float> full_volume() {
  return ellipse_body(kFullDims, {0.8, 0.8, 1.0}, 0.6, 0.4);
}

// Times deformer.update alternating the two frames (after 4 warm-up updates) and reports the
// ROI's elements, the voxels written and the ChainMail's and the resampling's shares; returns the
// last update's result.
palp::DeformResult time_alternating(benchmark::State& state, palp::SkinDeformer& deformer,
                                    const std::vector<palp::DeformContact> (&frames)[2],
                                    std::vector<float>& out) {
  palp::DeformResult last;
  std::int64_t frame = 0;
  double solve = 0, resample = 0;
  for (int warm = 0; warm < 4; ++warm) last = deformer.update(frames[warm % 2], out);
  for (auto _ : state) {
    last = deformer.update(frames[frame++ % 2], out);
    solve += last.solve_seconds;
    resample += last.resample_seconds;
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["roi_elements"] = static_cast<double>(last.elements);
  state.counters["written_voxels"] = static_cast<double>(
      (last.hi[0] - last.lo[0]) * (last.hi[1] - last.lo[1]) * (last.hi[2] - last.lo[2]));
  state.counters["solve_ms"] = 1e3 * solve / static_cast<double>(frame);
  state.counters["resample_ms"] = 1e3 * resample / static_cast<double>(frame);
  return last;
}

// Full resolution (issue 15): the 512 x 512 x 400 CT at 0.8 x 0.8 x 1 mm, finger:37 pressed
// 6 mm, with the ROI margin given (mm), ChainMail on every voxel (lattice 0) or on 1.6 mm
// elements (the default), and the ChainMail's and the resampling's shares.
void BM_SkinDeformFull(benchmark::State& state) {
  constexpr std::array<std::int64_t, 3> dims = kFullDims;
  constexpr std::array<double, 3> spacing{0.8, 0.8, 1.0};
  static const std::vector<float> original = full_volume();
  palp::DeformerParams params;
  params.roi_margin_mm = static_cast<double>(state.range(0));
  params.lattice_mm = 0.1 * static_cast<double>(state.range(1));  // 0: an element a voxel
  palp::SkinDeformer deformer(dims, spacing, original, params);
  std::vector<float> out = original;
  const std::vector<palp::DeformContact> frames[2] = {press(37, 204.8, 200.0, 6.0),
                                                      press(37, 205.6, 200.0, 6.0)};
  time_alternating(state, deformer, frames, out);
}
BENCHMARK(BM_SkinDeformFull)
    ->ArgsProduct({{20, 10}, {0, 16}})
    ->ArgNames({"margin_mm", "lattice_mm_x10"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// What palpview does on the 512 x 512 x 400 CT (issue 15; tests/bench/palpview_frames.sh with
// PALPVIEW_MAX_DIM=512, sim device finger:37), reproduced from the contacts its --stats-json
// recorded (deformation_split.last_contacts): the spacing arrives as float32 from the image
// header (0.8f mm), the pad lies on the body's flank (outward normal along -(1, 1, 0)) and is
// pressed 5 mm along the inward normal; sliding along the body axis (k), the proxies of the
// leading half lag 2.5 mm behind their contacts and those of the trailing half, still stuck,
// 3.5 to 10 mm. Args: slide (0: a still press, 1: sliding, the proxies spread over 17 mm along
// k) and the lattice as in BM_SkinDeformFull (0: an element a voxel, what palpview ran before the
// float32 spacing got its 2 x 2 x 1 lattice). Alternates two frames 0.8 mm apart along k.
std::vector<palp::DeformContact> flank_press(double shift_k, bool slide) {
  const double theta = std::numbers::pi + std::atan(kSemiY / kSemiX);
  const palp::Vec3d centre{kCentreX + kSemiX * std::cos(theta), kCentreY + kSemiY * std::sin(theta),
                           200.0 + shift_k};
  const palp::Vec3d inward = palp::Vec3d{1.0, 1.0, 0.0} * (1.0 / std::sqrt(2.0));
  const palp::Vec3d across = palp::Vec3d{1.0, -1.0, 0.0} * (1.0 / std::sqrt(2.0));
  std::vector<palp::DeformContact> contacts;
  const auto points = palp::finger_pad_points(37, 0.0);
  for (std::size_t m = 0; m < points.size(); ++m) {
    const palp::Vec3d rest = centre + across * points[m].x + palp::Vec3d{0.0, 0.0, points[m].y};
    const double lag =
        !slide ? 0.0 : (points[m].y >= 0.0 ? 2.5 : 3.5 + 6.5 * static_cast<double>(m % 7) / 6.0);
    contacts.push_back({rest + inward * 5.0, rest - palp::Vec3d{0.0, 0.0, lag}});
  }
  return contacts;
}

void BM_SkinDeformPalpview(benchmark::State& state) {
  static const std::vector<float> original = full_volume();
  const std::array<double, 3> spacing{static_cast<double>(0.8f), static_cast<double>(0.8f), 1.0};
  const bool slide = state.range(0) != 0;
  palp::DeformerParams params;
  params.lattice_mm = 0.1 * static_cast<double>(state.range(1));
  palp::SkinDeformer deformer(kFullDims, spacing, original, params);
  std::vector<float> out = original;
  const std::vector<palp::DeformContact> frames[2] = {flank_press(0.0, slide),
                                                      flank_press(0.8, slide)};
  const palp::DeformResult last = time_alternating(state, deformer, frames, out);
  state.counters["lattice_i"] = static_cast<double>(last.lattice[0]);
}
BENCHMARK(BM_SkinDeformPalpview)
    ->ArgsProduct({{0, 1}, {16, 0}})
    ->ArgNames({"slide", "lattice_mm_x10"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
