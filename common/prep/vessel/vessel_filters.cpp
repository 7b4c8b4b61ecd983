// The vessel search's two filters (see vessel_filters.hpp). Data flow:
//   smooth   CT -> means of three along i, then j (a slice buffer per thread), then k (the slice
//            below kept aside) -> 3x3x3 mean HU, one volume
//   ridges   CT -> per voxel at the ridge level: 13 directions, the means one and two voxels
//            away on both sides -> the directions along which it is a ridge (0 inside a thick
//            bright body)
#include "prep/vessel/vessel_filters.hpp"

#include <algorithm>
#include <cstdint>
#include <vector>

#include "base/parallel.hpp"

namespace palp {
namespace {

// The mean of three HU, rounded half away from zero.
inline std::int16_t mean_of_three(int a, int b, int c) {
  const int sum = a + b + c;
  return static_cast<std::int16_t>(sum >= 0 ? (sum + 1) / 3 : -((-sum + 1) / 3));
}

// One row's means of three along it (the end voxels repeated).
void mean_along_row(const std::int16_t* in, std::int16_t* out, std::int64_t n) {
  for (std::int64_t i = 0; i < n; ++i)
    out[i] = mean_of_three(in[i > 0 ? i - 1 : i], in[i], in[i + 1 < n ? i + 1 : i]);
}

// The means of three rows, voxel by voxel.
void mean_of_rows(const std::int16_t* lo, const std::int16_t* mid, const std::int16_t* hi,
                  std::int16_t* out, std::int64_t n) {
  for (std::int64_t i = 0; i < n; ++i) out[i] = mean_of_three(lo[i], mid[i], hi[i]);
}

// One of each pair of opposite directions to the 26 neighbours.
constexpr int kDirections[13][3] = {{1, 0, 0},  {0, 1, 0},  {0, 0, 1},  {1, 1, 0},  {1, -1, 0},
                                    {1, 0, 1},  {1, 0, -1}, {0, 1, 1},  {0, 1, -1}, {1, 1, 1},
                                    {1, 1, -1}, {1, -1, 1}, {1, -1, -1}};

// Rays (of 26) along which a voxel inside a thick bright body stays bright two voxels deep, at
// least: half of them, into the body. A shell is bright along its plane's 8 and a few more where
// it curves or thickens.
constexpr int kThickBodyRays = 13;

}  // namespace

// The 3x3x3 mean in one volume: each slice's means along i and j (through a slice buffer per
// thread) in place, then the means along k slice by slice with the slice below kept aside.
std::vector<std::int16_t> smoothed_hu(const CtVolume& ct) {
  const Grid& g = ct.grid;
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  const auto plane = static_cast<std::size_t>(nx * ny);
  std::vector<std::int16_t> out(ct.size());
  parallel_for_chunks(nz, 2, [&](std::int64_t k0, std::int64_t k1) {
    std::vector<std::int16_t> along_i(plane);
    for (std::int64_t k = k0; k < k1; ++k) {
      const std::int16_t* in = ct.data.data() + static_cast<std::size_t>(k) * plane;
      std::int16_t* to = out.data() + static_cast<std::size_t>(k) * plane;
      for (std::int64_t j = 0; j < ny; ++j)
        mean_along_row(in + j * nx, along_i.data() + j * nx, nx);
      for (std::int64_t j = 0; j < ny; ++j) {
        const std::int16_t* row = along_i.data() + j * nx;
        mean_of_rows(j > 0 ? row - nx : row, row, j + 1 < ny ? row + nx : row, to + j * nx, nx);
      }
    }
  });
  std::vector<std::int16_t> below(plane), here(plane);
  for (std::int64_t k = 0; k < nz; ++k) {
    std::int16_t* slice = out.data() + static_cast<std::size_t>(k) * plane;
    std::copy(slice, slice + plane, here.begin());
    const std::int16_t* lo = k > 0 ? below.data() : here.data();
    const std::int16_t* hi = k + 1 < nz ? slice + plane : here.data();
    mean_of_rows(lo, here.data(), hi, slice, static_cast<std::int64_t>(plane));
    std::swap(below, here);
  }
  return out;
}

Mask ridge_cortex(const CtVolume& ct, double level_hu, double soft_hu, double drop) {
  const Grid& g = ct.grid;
  Mask cortex(g, 0, "cortex");
  const std::int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  std::int64_t step[13];  // one voxel along each direction, as a linear offset
  for (int d = 0; d < 13; ++d)
    step[d] = kDirections[d][0] + nx * (kDirections[d][1] + ny * kDirections[d][2]);
  parallel_for_chunks(nz, 2, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < ny; ++j) {
        const std::int16_t* row = &ct.data[g.linear(0, j, k)];
        // two voxels from every face of the scan: both neighbours along every direction in it
        const bool inner_row = j >= 2 && j + 2 < ny && k >= 2 && k + 2 < nz;
        for (std::int64_t i = 0; i < nx; ++i) {
          const double v = row[i];
          if (v < level_hu) continue;
          const double below = v - drop * (v - soft_hu);
          const bool inner = inner_row && i >= 2 && i + 2 < nx;
          const std::int16_t* at = row + i;
          const auto side = [&](int d, int sign) {  // mean of 1 and 2 voxels away
            if (inner) {
              const std::int64_t o = sign * step[d];
              return 0.5 * (0.0 + at[o] + at[2 * o]);
            }
            double sum = 0.0;
            for (int s = 1; s <= 2; ++s) {
              const std::int64_t a =
                  std::clamp<std::int64_t>(i + s * sign * kDirections[d][0], 0, nx - 1);
              const std::int64_t b =
                  std::clamp<std::int64_t>(j + s * sign * kDirections[d][1], 0, ny - 1);
              const std::int64_t c =
                  std::clamp<std::int64_t>(k + s * sign * kDirections[d][2], 0, nz - 1);
              sum += ct.at(a, b, c);
            }
            return 0.5 * sum;
          };
          int ridge = 0;        // directions along which it is a ridge
          int bright_rays = 0;  // of the 26: rays along which it stays bright two voxels deep
          for (int d = 0; d < 13; ++d) {
            const double ahead = side(d, 1), behind = side(d, -1);
            ridge += ahead < below && behind < below;
            bright_rays += (ahead >= below) + (behind >= below);
          }
          // A corner of a thick bright body is dark on both sides along a tangent too, but
          // bright along half the rays or more, into it; a shell only along its own plane.
          cortex.at(i, j, k) = bright_rays < kThickBodyRays ? static_cast<std::uint8_t>(ridge) : 0;
        }
      }
  });
  return cortex;
}

}  // namespace palp
