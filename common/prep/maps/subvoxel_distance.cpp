// Sub-voxel signed distance maps (see subvoxel_distance.hpp).
//
// Every stage runs over slices in parallel. The near band writes only the slices its chunk
// owns and reads the points of the slices within the band of them, so no two threads write the
// same voxel. It takes the minimum of the far field and the discs within the band: a disc is
// never farther than its point, so wherever the nearest point lies within the band the result is
// the nearest disc's distance, and elsewhere it stays the distance to the points.
#include "prep/maps/subvoxel_distance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/maps/distance_transform.hpp"
#include "prep/maps/lower_envelope.hpp"
#include "prep/maps/map_rounding.hpp"

namespace palp {
namespace {

// ---- Far field: the exact distance to the point set ----------------------------------------
// Every point lies on a grid edge, so two of its coordinates are whole voxel indices and one
// (along the edge's axis a) is fractional. For the points of one axis a the squared distance
// min_p |x - p|^2 is separable: a 1D pass along a with the points' real positions (the nearest
// one to the left or right of each voxel), then lower envelopes of parabolas along the other two
// axes. The minimum over the three families is the distance to all points.

constexpr float kNone = std::numeric_limits<float>::infinity();

// Lower envelope of y = f[q] + w2 (x - q)^2 over the q with f[q] <= reach2, written over f
// (lower_envelope.hpp; each site keeps its f, so f itself can be overwritten without a copy).
void envelope_on_line(LowerEnvelope& envelope, float* f, std::int64_t n, double w2, double reach2) {
  // f <= reach2 exactly when f <= the largest float not above reach2 (a float compare).
  float reach2f = static_cast<float>(reach2);
  if (static_cast<double>(reach2f) > reach2)
    reach2f = std::nextafter(reach2f, -std::numeric_limits<float>::infinity());
  const auto site = [f, reach2f](std::int64_t q, double& fq) {
    if (!(f[q] <= reach2f)) return false;
    fq = f[q];
    return true;
  };
  if (envelope.build(n, w2, site) == 0) {
    std::fill(f, f + n, kNone);
    return;
  }
  envelope.for_each_span(n, [f, w2](std::int64_t x0, std::int64_t x1, std::int64_t q, double fq) {
    for (std::int64_t x = x0; x < x1; ++x) {
      const double c = static_cast<double>(x - q);
      f[x] = static_cast<float>(fq + w2 * c * c);
    }
  });
}

// 1D pass along a line: on entry f[q] holds the fraction t of the point on the edge (q, q+1), or
// a negative value for none; on exit the squared distance (mm^2) to the nearest point, or kNone.
// A voxel x sees the nearest point on an edge q < x (at q + t, below it) and the nearest on an
// edge q >= x (above it); both are found by walking the line's points in order.
void nearest_on_line(float* f, std::int64_t n, double w, std::vector<double>& points) {
  points.clear();
  for (std::int64_t q = 0; q < n; ++q)
    if (f[q] >= 0.0f) points.push_back(static_cast<double>(q) + f[q]);
  if (points.empty()) {  // most lines
    std::fill(f, f + n, kNone);
    return;
  }
  // Point p lies on edge floor(p): voxels x <= floor(p) have it above, the others below.
  std::int64_t x = 0;
  for (std::size_t p = 0; p <= points.size(); ++p) {
    const bool has_above = p < points.size();
    const std::int64_t end = has_above ? static_cast<std::int64_t>(points[p]) + 1 : n;
    for (; x < end; ++x) {
      float d2 = kNone;
      if (p > 0) {
        const double d = (static_cast<double>(x) - points[p - 1]) * w;
        d2 = static_cast<float>(d * d);
      }
      if (has_above) {
        const double d = (points[p] - static_cast<double>(x)) * w;
        d2 = std::min(d2, static_cast<float>(d * d));
      }
      f[x] = d2;
    }
  }
}

// Runs `line(values, length)` over every line of `g` along `axis`, gathering blocks of adjacent
// lines so strided reads fetch whole cache lines.
// Blocks of lines holding only kNone are skipped (an envelope leaves them so). The 1D pass's
// input marks "no point" as -1, so its blocks are never skipped.
template <class Line>
void over_lines(std::vector<float>& g, const Index3& n, int axis, unsigned threads, Line line) {
  const std::size_t stride[3] = {1, static_cast<std::size_t>(n[0]),
                                 static_cast<std::size_t>(n[0] * n[1])};
  const std::int64_t length = n[axis];
  if (axis == 0) {
    parallel_for_chunks(
        n[1] * n[2], 64,
        [&](std::int64_t r0, std::int64_t r1) {
          for (std::int64_t r = r0; r < r1; ++r)
            line(&g[static_cast<std::size_t>(r) * stride[1]], length);
        },
        threads);
    return;
  }
  // Lines along 1 or 2, in blocks of kWidth adjacent lines along axis 0.
  constexpr std::int64_t kWidth = 16;
  const int other = axis == 1 ? 2 : 1;
  const std::int64_t blocks = (n[0] + kWidth - 1) / kWidth;
  parallel_for_chunks(
      blocks * n[other], 4,
      [&](std::int64_t b0, std::int64_t b1) {
        std::vector<float> block(static_cast<std::size_t>(length * kWidth));
        for (std::int64_t b = b0; b < b1; ++b) {
          const std::int64_t i0 = (b % blocks) * kWidth;
          const std::int64_t width = std::min(kWidth, n[0] - i0);
          const std::size_t first =
              static_cast<std::size_t>(i0) + static_cast<std::size_t>(b / blocks) * stride[other];
          bool any = false;
          for (std::int64_t p = 0; p < length; ++p)
            for (std::int64_t w = 0; w < width; ++w) {
              const float v = g[first + static_cast<std::size_t>(p) * stride[axis] +
                                static_cast<std::size_t>(w)];
              block[static_cast<std::size_t>(w * length + p)] = v;
              any = any || v != kNone;
            }
          if (!any) continue;
          for (std::int64_t w = 0; w < width; ++w)
            line(&block[static_cast<std::size_t>(w * length)], length);
          for (std::int64_t p = 0; p < length; ++p)
            for (std::int64_t w = 0; w < width; ++w)
              g[first + static_cast<std::size_t>(p) * stride[axis] + static_cast<std::size_t>(w)] =
                  block[static_cast<std::size_t>(w * length + p)];
        }
      },
      threads);
}

// Runs fn(line, length) along axis 1 of one slice (n0 x n1 values, rows along axis 0), 16
// adjacent columns at a time through a buffer, so each row segment read is one cache line.
template <class Fn>
void along_columns(float* slice, std::int64_t n0, std::int64_t n1, std::vector<float>& columns,
                   Fn fn) {
  constexpr std::int64_t kWidth = 16;
  columns.resize(static_cast<std::size_t>(n1 * kWidth));
  for (std::int64_t i0 = 0; i0 < n0; i0 += kWidth) {
    const std::int64_t width = std::min(kWidth, n0 - i0);
    for (std::int64_t j = 0; j < n1; ++j)
      for (std::int64_t w = 0; w < width; ++w)
        columns[static_cast<std::size_t>(w * n1 + j)] =
            slice[static_cast<std::size_t>(j * n0 + i0 + w)];
    for (std::int64_t w = 0; w < width; ++w) fn(&columns[static_cast<std::size_t>(w * n1)], n1);
    for (std::int64_t j = 0; j < n1; ++j)
      for (std::int64_t w = 0; w < width; ++w)
        slice[static_cast<std::size_t>(j * n0 + i0 + w)] =
            columns[static_cast<std::size_t>(w * n1 + j)];
  }
}

// Runs fn(row, length) along axis 0 of one slice.
template <class Fn>
void along_rows(float* slice, std::int64_t n0, std::int64_t n1, Fn fn) {
  for (std::int64_t j = 0; j < n1; ++j) fn(slice + j * n0, n0);
}

// The points on edges along axis 2, grouped by column (i, j) and ordered by k within each: the
// 1D pass along axis 2 needs, for a voxel, only the nearest of them below and above it in its
// column, so it is evaluated slice by slice without a volume of its own.
struct Columns {
  std::vector<std::uint32_t> begin;  // column c = j * n0 + i: entries [begin[c], begin[c + 1])
  std::vector<std::int32_t> k;       // the edge's lower voxel along axis 2
  std::vector<float> t;              // the point's fraction along the edge

  explicit Columns(const SurfacePoints& surface) {
    const Index3 n = surface.grid.dims;
    const std::size_t columns = static_cast<std::size_t>(n[0] * n[1]);
    begin.assign(columns + 1, 0);
    for (const SurfacePoint& p : surface.points)
      if (p.axis == 2) ++begin[column(p, n) + 1];
    for (std::size_t c = 0; c < columns; ++c) begin[c + 1] += begin[c];
    k.resize(begin[columns]);
    t.resize(begin[columns]);
    std::vector<std::uint32_t> fill(begin.begin(), begin.end() - 1);
    for (const SurfacePoint& p : surface.points) {  // in order of k: each column comes out sorted
      if (p.axis != 2) continue;
      const std::uint32_t at = fill[column(p, n)]++;
      k[at] = p.k;
      t[at] = p.t;
    }
  }
  static std::size_t column(const SurfacePoint& p, const Index3& n) {
    return static_cast<std::size_t>(p.j) * static_cast<std::size_t>(n[0]) +
           static_cast<std::size_t>(p.i);
  }
  // First entry of column c at or above slice z (cursor: the column's entries below z skipped).
  std::uint32_t first_at_or_above(std::size_t c, std::int64_t z) const {
    return static_cast<std::uint32_t>(
        std::lower_bound(k.begin() + begin[c], k.begin() + begin[c + 1], z) - k.begin());
  }
};

// One slice of the 1D pass along axis 2 (what nearest_on_line would give along each column):
// the squared distance (mm^2) to the nearest axis-2 point of the voxel's column, kNone where
// the column has none. `cursor[c]` is column c's first entry at or above slice z - 1 on entry,
// z on exit.
void nearest_along_columns(const Columns& columns, std::int64_t z, double w,
                           std::vector<std::uint32_t>& cursor, float* slice) {
  const std::size_t count = cursor.size();
  for (std::size_t c = 0; c < count; ++c) {
    const std::uint32_t b = columns.begin[c], e = columns.begin[c + 1];
    if (b == e) {
      slice[c] = kNone;
      continue;
    }
    std::uint32_t at = cursor[c];
    while (at < e && columns.k[at] < z) ++at;
    cursor[c] = at;
    const double x = static_cast<double>(z);
    float f = kNone;
    if (at > b) {  // the nearest point below: on edge (q, q + 1) with q < z
      const double last = static_cast<double>(columns.k[at - 1]) + columns.t[at - 1];
      const double d = (x - last) * w;
      f = static_cast<float>(d * d);
    }
    if (at < e) {  // the nearest at or above: q >= z
      const double next = static_cast<double>(columns.k[at]) + columns.t[at];
      const double d = (next - x) * w;
      f = std::min(f, static_cast<float>(d * d));
    }
    slice[c] = f;
  }
}

// out = squared distance to the points (mm^2), capped at reach2 (kNone beyond).
// The envelope passes are min-plus convolutions, so they distribute over a minimum: the points
// on edges along axes 0 and 1 share their pass along axis 2. Order of work:
//   per slice   axis-0 points: nearest along 0, envelope along 1; axis-1 points: nearest along
//               1, envelope along 0; out = the minimum of the two
//   whole grid  envelope of out along 2
//   per slice   axis-2 points: nearest along 2 (from their columns), envelopes along 0 and 1;
//               out = min(out, that); then finish(k, slice of out), the slice being final
// The per-slice steps work in cache-sized buffers; only one pass touches the whole grid, and
// no second volume is needed.
template <class Finish>
void squared_point_distance(const SurfacePoints& surface, double reach2, std::vector<float>& out,
                            unsigned threads, Finish finish) {
  const Grid& grid = surface.grid;
  const Index3 n = grid.dims;
  const std::size_t slice_size = static_cast<std::size_t>(n[0] * n[1]);
  const double s0 = grid.spacing[0], s1 = grid.spacing[1], s2 = grid.spacing[2];
  auto envelope = [reach2](double w2) {
    return [w2, reach2](float* f, std::int64_t len) {
      thread_local LowerEnvelope lines;
      if (lines.capacity() < len) lines.reserve(len);
      envelope_on_line(lines, f, len, w2, reach2);
    };
  };
  auto nearest = [](double w) {
    return [w](float* f, std::int64_t len) {
      thread_local std::vector<double> points;
      nearest_on_line(f, len, w, points);
    };
  };

  parallel_for_chunks(
      n[2], 1,
      [&](std::int64_t k0, std::int64_t k1) {
        std::vector<float> a(slice_size), b(slice_size), column;
        for (std::int64_t k = k0; k < k1; ++k) {
          std::fill(a.begin(), a.end(), -1.0f);
          std::fill(b.begin(), b.end(), -1.0f);
          const auto kk = static_cast<std::size_t>(k);
          for (std::size_t pi = surface.slice_begin[kk]; pi < surface.slice_begin[kk + 1]; ++pi) {
            const SurfacePoint& p = surface.points[pi];
            const std::size_t at = static_cast<std::size_t>(p.j) * static_cast<std::size_t>(n[0]) +
                                   static_cast<std::size_t>(p.i);
            if (p.axis == 0) a[at] = p.t;
            if (p.axis == 1) b[at] = p.t;
          }
          along_rows(a.data(), n[0], n[1], nearest(s0));
          along_columns(a.data(), n[0], n[1], column, envelope(s1 * s1));
          along_columns(b.data(), n[0], n[1], column, nearest(s1));
          along_rows(b.data(), n[0], n[1], envelope(s0 * s0));
          float* target = &out[grid.linear(0, 0, k)];
          for (std::size_t v = 0; v < slice_size; ++v) target[v] = std::min(a[v], b[v]);
        }
      },
      threads);
  over_lines(out, n, 2, threads, envelope(s2 * s2));

  const Columns columns(surface);
  // Chunks of several slices, so a chunk's cursors are searched once and then advanced.
  const std::int64_t grain = std::max<std::int64_t>(1, n[2] / (8 * std::max(1u, threads)));
  parallel_for_chunks(
      n[2], grain,
      [&](std::int64_t k0, std::int64_t k1) {
        std::vector<float> slice(slice_size), column;
        std::vector<std::uint32_t> cursor(slice_size);
        for (std::size_t c = 0; c < slice_size; ++c) cursor[c] = columns.first_at_or_above(c, k0);
        for (std::int64_t k = k0; k < k1; ++k) {
          nearest_along_columns(columns, k, s2, cursor, slice.data());
          along_rows(slice.data(), n[0], n[1], envelope(s0 * s0));
          along_columns(slice.data(), n[0], n[1], column, envelope(s1 * s1));
          float* target = &out[grid.linear(0, 0, k)];
          for (std::size_t v = 0; v < slice_size; ++v) target[v] = std::min(target[v], slice[v]);
          finish(k, target);
        }
      },
      threads);
}

// Slices [k0, k1) of `map` rounded to 1/1024 mm (map_rounding.hpp) and clamped to +-clamp.
void round_and_clamp(DistanceMap& map, std::int64_t k0, std::int64_t k1, float clamp) {
  const Grid& grid = map.grid;
  const std::size_t count = static_cast<std::size_t>(grid.dims[0] * grid.dims[1]);
  for (std::int64_t k = k0; k < k1; ++k) {
    float* slice = &map.data[grid.linear(0, 0, k)];
    for (std::size_t v = 0; v < count; ++v) {
      const float rounded = round_to_map_step(slice[v]);
      const float above = rounded < -clamp ? -clamp : rounded;  // std::clamp, by value:
      slice[v] = clamp < above ? clamp : above;                 // a select vectorizes
    }
  }
}

// Within `band_mm` of each point: the minimum of |map| and the distance to the point's disc,
// signed by the mask; then everything rounded and clamped.
void refine_near_surface(const SurfacePoints& surface, const Mask& mask, double band_mm,
                         double clamp_mm, DistanceMap& map, unsigned threads) {
  const Grid& grid = surface.grid;
  if (map.grid.dims != grid.dims || mask.grid.dims != grid.dims ||
      map.data.size() != grid.voxel_count() || mask.data.size() != grid.voxel_count()) {
    throw UsageError("sub-voxel refinement: the map, the mask and the points differ in grid");
  }
  if (!(band_mm > 0.0)) throw UsageError("sub-voxel band must be positive");
  threads = thread_count_or_default(threads);
  const Index3 n = grid.dims;
  const Vec3 s = grid.spacing;
  // The disc radius: half the diagonal of the two coarsest spacings, so the discs around the
  // points of any plane leave no gap (the points of a plane lie at most that far apart / 2).
  Vec3 sorted = s;
  std::sort(sorted.begin(), sorted.end());
  const double radius = 0.5 * std::hypot(sorted[1], sorted[2]);
  const double r2 = radius * radius;
  const double band2 = band_mm * band_mm;
  Index3 reach;
  for (int a = 0; a < 3; ++a) reach[a] = static_cast<std::int64_t>(std::ceil(band_mm / s[a])) + 1;
  const float clamp = static_cast<float>(clamp_mm);

  parallel_for_chunks(
      n[2], 2,
      [&](std::int64_t k0, std::int64_t k1) {
        const std::int64_t first_slice = std::max<std::int64_t>(0, k0 - reach[2]);
        const std::int64_t last_slice = std::min<std::int64_t>(n[2], k1 + reach[2]);
        const std::size_t p0 = surface.slice_begin[static_cast<std::size_t>(first_slice)];
        const std::size_t p1 = surface.slice_begin[static_cast<std::size_t>(last_slice)];
        {
          for (std::size_t pi = p0; pi < p1; ++pi) {
            const SurfacePoint& p = surface.points[pi];
            const double pos[3] = {p.x, p.y, p.z};
            std::int64_t lo[3], hi[3];
            for (int a = 0; a < 3; ++a) {
              lo[a] = std::max<std::int64_t>(
                  0, static_cast<std::int64_t>(std::ceil((pos[a] - band_mm) / s[a])));
              hi[a] = std::min<std::int64_t>(
                  n[a] - 1, static_cast<std::int64_t>(std::floor((pos[a] + band_mm) / s[a])));
            }
            lo[2] = std::max(lo[2], k0);
            hi[2] = std::min(hi[2], k1 - 1);
            for (std::int64_t k = lo[2]; k <= hi[2]; ++k) {
              const double dz = static_cast<double>(k) * s[2] - pos[2];
              for (std::int64_t j = lo[1]; j <= hi[1]; ++j) {
                const double dy = static_cast<double>(j) * s[1] - pos[1];
                const double dyz2 = dy * dy + dz * dz;
                if (dyz2 > band2) continue;
                const std::size_t row = grid.linear(0, j, k);
                float* out = &map.data[row];
                const std::uint8_t* in = &mask.data[row];
                for (std::int64_t i = lo[0]; i <= hi[0]; ++i) {
                  const double dx = static_cast<double>(i) * s[0] - pos[0];
                  const double d2 = dx * dx + dyz2;
                  if (d2 > band2) continue;
                  const double along = dx * p.nx + dy * p.ny + dz * p.nz;
                  const double lateral2 = std::max(0.0, d2 - along * along);
                  double d;
                  if (lateral2 <= r2) {
                    d = std::abs(along);
                  } else {
                    const double beyond = std::sqrt(lateral2) - radius;
                    d = std::sqrt(beyond * beyond + along * along);
                  }
                  const float df = static_cast<float>(d);
                  if (df < std::abs(out[i])) out[i] = in[i] ? df : -df;
                }
              }
            }
          }
        }
        round_and_clamp(map, k0, k1, clamp);
      },
      threads);
}

}  // namespace

void subvoxel_signed_distance(const SurfacePoints& surface, const Mask& mask, double band_mm,
                              double clamp_mm, DistanceMap& out, unsigned threads) {
  const Grid& grid = surface.grid;
  if (mask.grid.dims != grid.dims || mask.data.size() != grid.voxel_count()) {
    throw UsageError("sub-voxel distance: the mask and the points differ in grid");
  }
  check_distance_band(clamp_mm);
  threads = thread_count_or_default(threads);
  if (out.data.size() != grid.voxel_count()) {
    out = DistanceMap();
    out = DistanceMap(grid, 0.0f, "distance map");
  }
  out.grid = grid;
  // Each slice, once final, becomes the distance, clamped and signed by the mask.
  const float clamp = static_cast<float>(clamp_mm);
  const std::size_t slice_size = static_cast<std::size_t>(grid.dims[0] * grid.dims[1]);
  squared_point_distance(surface, clamp_mm * clamp_mm, out.data, threads,
                         [&](std::int64_t k, float* slice) {
                           const std::uint8_t* in = &mask.data[grid.linear(0, 0, k)];
                           for (std::size_t v = 0; v < slice_size; ++v) {
                             const float d = std::min(clamp, std::sqrt(slice[v]));
                             slice[v] = in[v] ? d : -d;
                           }
                         });
  refine_near_surface(surface, mask, band_mm, clamp_mm, out, threads);
}

}  // namespace palp
