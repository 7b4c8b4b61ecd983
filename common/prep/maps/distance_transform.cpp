// Exact signed Euclidean distance transform (see distance_transform.hpp for the convention).
//
// Data flow, all in place in the output array (4 bytes a voxel, no second volume):
//   crop      mask -> box around the inside voxels + band margin; outside it D = -band
//   pass i    mask rows            -> per voxel: offset (in voxels, along i) to the nearest voxel
//                                     of the opposite class, packed as (a, 0)
//   pass j    (a, 0) columns       -> per voxel: offsets (a, b) of the nearest opposite-class
//                                     voxel within its axial slice (lower envelope of parabolas)
//   pass k    (a, b) lines along k -> float D: min over k' of |(a sx, b sy, (k-k') sz)|, signed,
//                                     offset by h/2, clamped to the band
// Each pass answers two questions at once: "nearest outside" for inside voxels and "nearest
// inside" for outside voxels. The source values of both can be rebuilt from the one packed
// value and the mask, because a voxel's distance to its own class is zero.
//
// Offsets are stored as integers, so the final squared distance is evaluated exactly as a
// brute-force search would evaluate it: (a sx)^2 + (b sy)^2 + (c sz)^2 in double.
#include "prep/maps/distance_transform.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/maps/lower_envelope.hpp"
#include "prep/segment/morphology.hpp"

namespace palp {
namespace {

// Packed per-voxel offsets during the passes: low 16 bits along i, high 16 bits along j.
// kNoSite marks "no voxel of the wanted class on this line/slice" (infinite distance).
constexpr std::uint32_t kNoSite = 0xFFFFFFFFu;
constexpr std::uint16_t kNoOffset = 0xFFFFu;
static_assert(kMaxVoxelsPerAxis < kNoOffset, "offsets must fit below the sentinel");

inline std::uint32_t pack(std::uint32_t a, std::uint32_t b) {
  return a | (b << 16);
}
inline std::uint32_t offset_a(std::uint32_t packed) {
  return packed & 0xFFFFu;
}
inline std::uint32_t offset_b(std::uint32_t packed) {
  return packed >> 16;
}

// Reads and writes packed offsets in the float output array without aliasing it as uint32.
struct PackedView {
  float* storage;
  struct Ref {
    float* at;
    operator std::uint32_t() const { return std::bit_cast<std::uint32_t>(*at); }
    Ref& operator=(std::uint32_t v) {
      *at = std::bit_cast<float>(v);
      return *this;
    }
  };
  Ref operator[](std::size_t i) const { return Ref{storage + i}; }
};

using segmentation::VoxelBox;

// Pass i over one row: offset along i to the nearest voxel of the opposite class, for the
// classes in `wanted` (bit 0 outside, bit 1 inside); the others get 0, the bits of 0.0f, which
// they keep through the passes.
void pass_rows(const std::uint8_t* mask_row, PackedView out, std::size_t first, std::int64_t n,
               unsigned wanted) {
  std::int64_t last[2] = {-1, -1};  // last index seen of class 0 / 1
  for (std::int64_t i = 0; i < n; ++i) {
    const int cls = mask_row[i] != 0;
    last[cls] = i;
    const std::int64_t opposite = last[1 - cls];
    out[first + static_cast<std::size_t>(i)] = (wanted >> cls & 1u) == 0 ? 0u
                                               : opposite < 0
                                                   ? std::uint32_t{kNoOffset}
                                                   : static_cast<std::uint32_t>(i - opposite);
  }
  last[0] = last[1] = -1;
  for (std::int64_t i = n - 1; i >= 0; --i) {
    const int cls = mask_row[i] != 0;
    last[cls] = i;
    const std::int64_t opposite = last[1 - cls];
    if (opposite < 0 || (wanted >> cls & 1u) == 0) continue;
    const std::uint32_t backward = static_cast<std::uint32_t>(opposite - i);
    auto slot = out[first + static_cast<std::size_t>(i)];
    if (backward < static_cast<std::uint32_t>(slot)) slot = backward;
  }
}

// The squared in-plane distance a packed (a, b) stands for; -1 when there is no site.
inline double squared_distance(std::uint32_t packed, double sx2, double sy2) {
  if (packed == kNoSite || offset_a(packed) == kNoOffset) return -1.0;
  const double a = offset_a(packed), b = offset_b(packed);
  return a * a * sx2 + b * b * sy2;
}

// Per-thread scratch for the line passes (j and k): a block of kWidth adjacent lines gathered
// side by side, so each strided read of the volume fetches whole cache lines.
struct LineBlock {
  static constexpr std::int64_t kWidth = 16;
  std::int64_t length = 0;            // voxels per line
  std::vector<std::uint8_t> cls;      // [position * kWidth + line]: 1 inside, 0 outside
  std::vector<std::uint32_t> value;   // [position * kWidth + line]: packed offsets / float bits
  std::vector<double> f;              // one line's parabola heights
  std::vector<std::int32_t> argmin;   // one line's winning sites
  std::vector<std::uint32_t> staged;  // one line's results, committed once both classes are done
  LowerEnvelope envelope;

  explicit LineBlock(std::int64_t n) : length(n) {
    const auto size = static_cast<std::size_t>(n);
    cls.resize(size * kWidth);
    value.resize(size * kWidth);
    f.resize(size);
    argmin.resize(size);
    staged.resize(size);
    envelope.reserve(n);
  }
  std::size_t at(std::int64_t position, std::int64_t line) const {
    return static_cast<std::size_t>(position * kWidth + line);
  }

  // For target class t, the sources along a line are the voxels of class 1-t (height 0) and the
  // voxels of class t, whose height is the squared distance `height(value)` they already reach
  // to class 1-t in the lower dimensions. Sites beyond `reach2` only yield clamped values and
  // are dropped, and so are those farther along the line than reach2 from every voxel of class
  // t (a sparse class's lines need only their stretch). Calls emit(position, site) for each
  // voxel of class t.
  template <class Height, class Emit>
  void solve(std::int64_t line, int target, double w2, double reach2, Height height, Emit emit) {
    std::int64_t t0 = length, t1 = -1;  // first and last voxel of class t
    for (std::int64_t x = 0; x < length; ++x)
      if (cls[at(x, line)] == target) t0 = std::min(t0, x), t1 = x;
    if (t1 < 0) return;
    const double reach_steps = std::ceil(std::sqrt(reach2 / w2)) + 1.0;
    const std::int64_t r =
        reach_steps < static_cast<double>(length) ? static_cast<std::int64_t>(reach_steps) : length;
    const std::int64_t lo = std::max<std::int64_t>(0, t0 - r);
    const std::int64_t hi = std::min(length, t1 + r + 1);
    for (std::int64_t q = lo; q < hi; ++q) {
      const std::size_t i = at(q, line);
      const double fq = cls[i] != target ? 0.0 : height(value[i]);
      f[static_cast<std::size_t>(q)] = fq > reach2 ? -1.0 : fq;
    }
    // f[q] < 0 marks "no site at q"; argmin[x] receives the winning site, or -1 without one.
    if (envelope.build(lo, hi, w2, [this](std::int64_t q, double& fq) {
          fq = f[static_cast<std::size_t>(q)];
          return !(fq < 0.0);
        }) == 0) {
      std::fill(argmin.begin() + lo, argmin.begin() + hi, -1);
    } else {
      envelope.for_each_span(
          lo, hi, [this](std::int64_t x0, std::int64_t x1, std::int64_t q, double) {
            std::fill(argmin.begin() + x0, argmin.begin() + x1, static_cast<std::int32_t>(q));
          });
    }
    for (std::int64_t x = t0; x <= t1; ++x) {
      if (cls[at(x, line)] == target) emit(x, argmin[static_cast<std::size_t>(x)]);
    }
  }

  // Stages the line's values as they are: the result for the classes not solved.
  void stage_values(std::int64_t line) {
    for (std::int64_t x = 0; x < length; ++x)
      staged[static_cast<std::size_t>(x)] = value[at(x, line)];
  }

  void commit_staged(std::int64_t line) {
    for (std::int64_t x = 0; x < length; ++x)
      value[at(x, line)] = staged[static_cast<std::size_t>(x)];
  }

  // Which classes occur on a line: bit 0 outside, bit 1 inside.
  unsigned classes(std::int64_t line) const {
    unsigned seen = 0;
    for (std::int64_t q = 0; q < length; ++q) seen |= 1u << cls[at(q, line)];
    return seen;
  }
};

// Runs `body(block, width)` over blocks of adjacent lines along `stride`, first voxel `first`:
// gathers mask classes and values, then scatters block.value back. A block without a voxel of
// the `wanted` classes is left as it is.
template <class Body>
void with_line_block(LineBlock& block, const Mask& mask, PackedView values, std::size_t first,
                     std::size_t stride, std::int64_t width, unsigned wanted, Body body) {
  unsigned seen = 0;
  for (std::int64_t p = 0; p < block.length; ++p) {
    const std::size_t at = first + static_cast<std::size_t>(p) * stride;
    for (std::int64_t w = 0; w < width; ++w) {
      const std::uint8_t cls = mask.data[at + static_cast<std::size_t>(w)] != 0;
      block.cls[block.at(p, w)] = cls;
      seen |= 1u << cls;
    }
  }
  if ((seen & wanted) == 0) return;
  for (std::int64_t p = 0; p < block.length; ++p) {
    const std::size_t at = first + static_cast<std::size_t>(p) * stride;
    for (std::int64_t w = 0; w < width; ++w)
      block.value[block.at(p, w)] = values[at + static_cast<std::size_t>(w)];
  }
  body(block, width);
  for (std::int64_t p = 0; p < block.length; ++p) {
    const std::size_t at = first + static_cast<std::size_t>(p) * stride;
    for (std::int64_t w = 0; w < width; ++w) {
      values[at + static_cast<std::size_t>(w)] = block.value[block.at(p, w)];
    }
  }
}

// Pass j on a block: packed (a, 0) -> packed (a, b), the nearest opposite voxel in the slice.
// A winning site of class t carries its own row offset a; one of class 1-t is the voxel itself.
// Only the classes in `wanted` (bit 0 outside, bit 1 inside) are solved; the others keep the 0
// pass i gave them.
void pass_j(LineBlock& block, std::int64_t width, double sx2, double sy2, double reach2,
            unsigned wanted) {
  auto row_height = [sx2](std::uint32_t a) {
    return a == kNoOffset ? -1.0 : static_cast<double>(a) * static_cast<double>(a) * sx2;
  };
  for (std::int64_t w = 0; w < width; ++w) {
    const unsigned present = block.classes(w) & wanted;
    if (present == 0) continue;
    if (wanted != 3u) block.stage_values(w);
    for (int target = 0; target < 2; ++target) {
      if ((present & (1u << target)) == 0) continue;
      block.solve(w, target, sy2, reach2, row_height, [&](std::int64_t x, std::int32_t q) {
        if (q < 0) {
          block.staged[static_cast<std::size_t>(x)] = kNoSite;
          return;
        }
        const std::size_t iq = block.at(q, w);
        const std::uint32_t a = block.cls[iq] == target ? block.value[iq] : 0u;
        block.staged[static_cast<std::size_t>(x)] =
            pack(a, static_cast<std::uint32_t>(std::abs(x - q)));
      });
    }
    block.commit_staged(w);
  }
}

// Pass k on a block: packed (a, b) -> float D, signed, offset by h/2 and clamped to the band.
// The classes not in `wanted` keep the 0 pass i gave them.
void pass_k(LineBlock& block, std::int64_t width, double sx2, double sy2, double sz2, double reach2,
            double h, float band, unsigned wanted) {
  auto plane_height = [sx2, sy2](std::uint32_t v) { return squared_distance(v, sx2, sy2); };
  for (std::int64_t w = 0; w < width; ++w) {
    const unsigned present = block.classes(w) & wanted;
    if (present == 0) continue;  // its voxels hold 0 since pass i
    if (wanted != 3u) block.stage_values(w);
    for (int target = 0; target < 2; ++target) {
      if ((present & (1u << target)) == 0) continue;
      block.solve(w, target, sz2, reach2, plane_height, [&](std::int64_t x, std::int32_t q) {
        float distance = band;  // no site within reach: beyond the band
        if (q >= 0) {
          const double c = static_cast<double>(x - q);
          const double d2 = block.f[static_cast<std::size_t>(q)] + c * c * sz2;
          distance = std::min(band, static_cast<float>(std::sqrt(d2) - h / 2.0));
        }
        // target 1: an inside voxel, positive; target 0: an outside voxel, negative.
        block.staged[static_cast<std::size_t>(x)] =
            std::bit_cast<std::uint32_t>(target == 1 ? distance : -distance);
      });
    }
    block.commit_staged(w);
  }
}

// `out` on `grid`, every voxel outside beyond the band (-band); its memory reused when it fits.
void fill_outside(const Grid& grid, float band, unsigned threads, DistanceMap& out) {
  if (out.data.size() == grid.voxel_count()) {
    out.grid = grid;
    parallel_for_chunks(
        grid.dims[2], 8,
        [&](std::int64_t k0, std::int64_t k1) {
          std::fill(out.data.begin() + static_cast<std::ptrdiff_t>(grid.linear(0, 0, k0)),
                    out.data.begin() + static_cast<std::ptrdiff_t>(grid.linear(0, 0, k1)), -band);
        },
        threads);
  } else {
    out = DistanceMap();  // release the old memory before taking the new
    out = DistanceMap(grid, -band, "distance map");
  }
}

// Crop: voxels farther than the band (+ h/2 offset, + one voxel) from the inside box are
// outside and clamped, so the transform only runs inside this box. The nearest site of every
// voxel in the box lies in the box (clamping a site onto the box never lengthens the path).
VoxelBox crop_box(const VoxelBox& inside, const Grid& grid, double band_mm) {
  const double h = grid.min_spacing();
  VoxelBox box;
  for (int a = 0; a < 3; ++a) {
    const auto margin = static_cast<std::int64_t>(std::ceil((band_mm + h) / grid.spacing[a])) + 1;
    box.lo[a] = std::max<std::int64_t>(0, inside.lo[a] - margin);
    box.hi[a] = std::min<std::int64_t>(grid.dims[a], inside.hi[a] + margin);
  }
  return box;
}

}  // namespace

DistanceMap signed_distance(const Mask& mask, const DistanceParams& params) {
  DistanceMap out;
  signed_distance(mask, params, out);
  return out;
}

void check_distance_band(double band_mm) {
  if (band_mm > 0.0 && band_mm <= kMaxBandMm) return;
  char text[96];
  std::snprintf(text, sizeof text, "--band must be in (0, %g] mm, got %g", kMaxBandMm, band_mm);
  throw UsageError(text);
}

void signed_distance(const Mask& mask, const DistanceParams& params, DistanceMap& out) {
  check_distance_band(params.band_mm);
  const Grid& grid = mask.grid;
  validate_grid(grid, "mask");
  if (mask.data.size() != grid.voxel_count()) throw UsageError("mask data does not match its grid");
  const unsigned threads = thread_count_or_default(params.threads);
  const float band = static_cast<float>(params.band_mm);
  const Index3 n = grid.dims;
  const double h = grid.min_spacing();

  fill_outside(grid, band, threads, out);
  const VoxelBox inside = segmentation::nonzero_box(mask, 0, threads);
  if (inside.size(0) <= 0) return;  // no inside voxel: everything is outside, beyond the band
  const VoxelBox box = crop_box(inside, grid, params.band_mm);
  const std::int64_t bx = box.size(0), by = box.size(1), bz = box.size(2);
  // The output array doubles as the packed-offset store until pass k turns it into floats.
  PackedView packed{out.data.data()};
  const double sx2 = grid.spacing[0] * grid.spacing[0];
  const double sy2 = grid.spacing[1] * grid.spacing[1];
  const double sz2 = grid.spacing[2] * grid.spacing[2];
  // Squared centre-to-centre distance beyond which D is clamped (sqrt(d2) - h/2 > band): sites
  // whose partial distance already exceeds it are dropped from the envelopes.
  const double reach2 = (params.band_mm + h) * (params.band_mm + h);
  const unsigned wanted = params.side == DistanceSide::inside    ? 2u
                          : params.side == DistanceSide::outside ? 1u
                                                                 : 3u;

  constexpr std::int64_t kWidth = LineBlock::kWidth;
  const std::int64_t blocks_per_row = (bx + kWidth - 1) / kWidth;
  const std::size_t row_stride = static_cast<std::size_t>(n[0]);
  const std::size_t slice_stride = static_cast<std::size_t>(n[0] * n[1]);

  // Passes i and j, slice by slice: mask rows -> packed (a, b) per voxel of the box.
  parallel_for_chunks(
      bz, 1,
      [&](std::int64_t z0, std::int64_t z1) {
        LineBlock block(by);
        for (std::int64_t k = box.lo[2] + z0; k < box.lo[2] + z1; ++k) {
          for (std::int64_t j = box.lo[1]; j < box.hi[1]; ++j) {
            const std::size_t at = grid.linear(box.lo[0], j, k);
            pass_rows(&mask.data[at], packed, at, bx, wanted);
          }
          for (std::int64_t b = 0; b < blocks_per_row; ++b) {
            const std::int64_t i0 = box.lo[0] + b * kWidth;
            with_line_block(block, mask, packed, grid.linear(i0, box.lo[1], k), row_stride,
                            std::min(kWidth, box.hi[0] - i0), wanted,
                            [&](LineBlock& lines, std::int64_t width) {
                              pass_j(lines, width, sx2, sy2, reach2, wanted);
                            });
          }
        }
      },
      threads);

  // Pass k over blocks of lines: packed (a, b) -> float D, written over the packed values.
  parallel_for_chunks(
      by * blocks_per_row, 8,
      [&](std::int64_t b0, std::int64_t b1) {
        LineBlock block(bz);
        for (std::int64_t b = b0; b < b1; ++b) {
          const std::int64_t j = box.lo[1] + b / blocks_per_row;
          const std::int64_t i0 = box.lo[0] + (b % blocks_per_row) * kWidth;
          with_line_block(block, mask, packed, grid.linear(i0, j, box.lo[2]), slice_stride,
                          std::min(kWidth, box.hi[0] - i0), wanted,
                          [&](LineBlock& lines, std::int64_t width) {
                            pass_k(lines, width, sx2, sy2, sz2, reach2, h, band, wanted);
                          });
        }
      },
      threads);
}

}  // namespace palp
