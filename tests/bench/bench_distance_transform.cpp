// Google Benchmark of the signed distance transform on an ellipsoidal body-like mask, across grid
// sizes and thread counts. Measures only; never part of CTest.
#include <benchmark/benchmark.h>

#include <cmath>

#include "prep/maps/distance_transform.hpp"

namespace {

palp::Mask ellipsoid_mask(std::int64_t n, double spacing) {
  palp::Grid grid;
  grid.dims = {n, n, n * 3 / 4};
  grid.spacing = {spacing, spacing, spacing * 1.5};
  palp::Mask mask(grid, 0);
  const double cx = 0.5 * n * spacing, cy = 0.47 * n * spacing;
  for (std::int64_t k = 0; k < grid.dims[2]; ++k)
    for (std::int64_t j = 0; j < n; ++j)
      for (std::int64_t i = 0; i < n; ++i) {
        const double x = (i * spacing - cx) / (0.39 * n * spacing);
        const double y = (j * spacing - cy) / (0.27 * n * spacing);
        mask.at(i, j, k) = x * x + y * y < 1.0 ? 1 : 0;
      }
  return mask;
}

void BM_SignedDistance(benchmark::State& state) {
  const palp::Mask mask = ellipsoid_mask(state.range(0), 0.8);
  const palp::DistanceParams params{60.0, static_cast<unsigned>(state.range(1))};
  for (auto _ : state) {
    palp::DistanceMap map = palp::signed_distance(mask, params);
    benchmark::DoNotOptimize(map.data.data());
  }
  state.counters["voxels/s"] = benchmark::Counter(static_cast<double>(mask.grid.voxel_count()),
                                                  benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_SignedDistance)
    ->ArgsProduct({{128, 256, 384}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
