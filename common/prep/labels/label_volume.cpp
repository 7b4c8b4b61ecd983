// Label voxels read slab by slab and put on the CT's grid. See label_volume.hpp.
#include "prep/labels/label_volume.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <type_traits>

#include "base/errors.hpp"
#include "io/gzip.hpp"

namespace palp::labels {
namespace {

InputError label_error(const LabelVolume& v, const std::string& message) {
  return InputError("labels: " + v.name + ": " + message);
}

// ---- geometry ----

using Mat3 = std::array<std::array<double, 3>, 3>;

// Label index coordinates of CT voxel ijk: m * ijk + t.
struct IndexMap {
  Mat3 m{};
  Vec3 t{};
};

// Columns: the grid's index axes in the world, scaled by the spacing (mm per voxel).
Mat3 axes(const Grid& g) {
  Mat3 a{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a[r][c] = g.world.direction[r * 3 + c] * g.spacing[c];
  return a;
}

std::optional<Mat3> inverse(const Mat3& a) {
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  double scale = 0.0;
  for (const auto& row : a)
    for (double v : row) scale = std::max(scale, std::fabs(v));
  if (!std::isfinite(det) || std::fabs(det) <= 1e-9 * scale * scale * scale) return std::nullopt;
  Mat3 inv{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
      inv[r][c] = (a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1]) / det;
    }
  }
  return inv;
}

// The map from `from`'s voxel indices to `to`'s; std::nullopt when `to`'s axes are degenerate.
// Within 1e-5 of the identity and 1e-3 voxel of a whole-voxel shift (the same lattice: the CT's
// own grid, or a box of it as 3D Slicer crops a segmentation), it is made exactly that.
std::optional<IndexMap> index_map(const Grid& from, const Grid& to) {
  const auto to_inverse = inverse(axes(to));
  if (!to_inverse) return std::nullopt;
  const Mat3& a = *to_inverse;
  const Mat3 b = axes(from);
  IndexMap map;
  bool aligned = true;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      for (int k = 0; k < 3; ++k) map.m[r][c] += a[r][k] * b[k][c];
      aligned = aligned && std::fabs(map.m[r][c] - (r == c ? 1.0 : 0.0)) < 1e-5;
    }
    for (int k = 0; k < 3; ++k) map.t[r] += a[r][k] * (from.world.origin[k] - to.world.origin[k]);
    aligned = aligned && std::fabs(map.t[r] - std::round(map.t[r])) < 1e-3;
  }
  if (aligned) {
    map.m = {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
    for (double& t : map.t) t = std::round(t) + 0.0;
  }
  return map;
}

// The same lattice: label voxels are CT voxels shifted by whole voxels.
bool is_aligned(const IndexMap& map) {
  return map.m == Mat3{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}} &&
         std::all_of(map.t.begin(), map.t.end(), [](double t) { return t == std::round(t); });
}

// floor(x + 0.5) without a call to floor (the per-voxel loops round three times a voxel).
std::int64_t nearest(double x) {
  const double y = x + 0.5;
  const auto n = static_cast<std::int64_t>(y);
  return n - (y < static_cast<double>(n) ? 1 : 0);
}

// The grid's voxel centres' box in the world (LPS mm), "[x0, x1] x [y0, y1] x [z0, z1] mm".
std::string world_box(const Grid& g) {
  Vec3 lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  const Mat3 a = axes(g);
  for (int corner = 0; corner < 8; ++corner) {
    for (int r = 0; r < 3; ++r) {
      double w = g.world.origin[r];
      for (int c = 0; c < 3; ++c)
        w += a[r][c] * static_cast<double>((corner >> c & 1) ? g.dims[c] - 1 : 0);
      lo[r] = std::min(lo[r], w);
      hi[r] = std::max(hi[r], w);
    }
  }
  char text[160];
  std::snprintf(text, sizeof text, "[%.0f, %.0f] x [%.0f, %.0f] x [%.0f, %.0f] mm", lo[0], hi[0],
                lo[1], hi[1], lo[2], hi[2]);
  return text;
}

// Refuses, before anything is read, a label grid no CT voxel centre falls into.
void check_overlap(const LabelVolume& v, const IndexMap& map, const Grid& ct) {
  const Grid& label = v.image.grid;
  for (int r = 0; r < 3; ++r) {
    double lo = 1e300, hi = -1e300;
    for (int corner = 0; corner < 8; ++corner) {
      double x = map.t[r];
      for (int c = 0; c < 3; ++c)
        x += map.m[r][c] * static_cast<double>((corner >> c & 1) ? ct.dims[c] - 1 : 0);
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    if (hi < -0.5 || lo >= static_cast<double>(label.dims[r]) - 0.5)
      throw InputError("labels: " + v.name +
                       " does not overlap the CT (in the patient's LPS world the labels span " +
                       world_box(label) + ", the CT " + world_box(ct) + ")");
  }
}

// ---- stored values ----

constexpr std::uint64_t kMaxDeflateRatio = 1032;  // deflate's largest expansion
constexpr std::size_t kChunkBytes = std::size_t{1} << 20;

[[noreturn]] void throw_short(const LabelVolume& v, std::uint64_t need, std::uint64_t have) {
  throw label_error(v, "header says " + std::to_string(need) + " bytes of voxel data, file has " +
                           std::to_string(have));
}

// Where the stream starts, after the header's claim was checked against the file's size.
std::uint64_t check_size(const LabelVolume& v, std::uint64_t need) {
  const StoredVoxels& s = v.image.voxels;
  const std::uint64_t size = file_size(s.path);
  if (s.compression == Compression::none) {
    if (s.at_end_of_file) {
      if (size < need) throw_short(v, need, size);
      return size - need;
    }
    const std::uint64_t begin = s.file_offset + s.skip;
    if ((size > begin ? size - begin : 0) < need)
      throw_short(v, need, size > begin ? size - begin : 0);
    return s.file_offset;
  }
  const std::uint64_t compressed = size > s.file_offset ? size - s.file_offset : 0;
  if (need + s.skip > compressed * kMaxDeflateRatio)
    throw label_error(v, "header says " + std::to_string(need) + " bytes of voxel data, file has " +
                             std::to_string(compressed) + " compressed bytes (at most " +
                             std::to_string(compressed * kMaxDeflateRatio) + " decompressed)");
  return s.file_offset;
}

// A value that is not a label: where it is and what it holds.
[[noreturn]] void throw_not_label(const LabelVolume& v, std::uint64_t at, double value) {
  const Grid& g = v.image.grid;
  const auto c = static_cast<std::int64_t>(at % static_cast<std::uint64_t>(v.components));
  const auto voxel = static_cast<std::int64_t>(at / static_cast<std::uint64_t>(v.components));
  const std::int64_t i = voxel % g.dims[0], j = voxel / g.dims[0] % g.dims[1],
                     k = voxel / g.dims[0] / g.dims[1];
  char text[64];
  std::snprintf(text, sizeof text, "%.9g", value);
  throw label_error(v, (v.components > 1 ? "layer " + std::to_string(c) + " of " : std::string()) +
                           "voxel (" + std::to_string(i) + ", " + std::to_string(j) + ", " +
                           std::to_string(k) + ") holds " + text +
                           ": not a label (labels are whole numbers 0..65535)");
}

template <class In>
void to_labels(const std::uint8_t* src, std::size_t n, const LabelVolume& v, std::uint64_t first,
               std::uint16_t* dst) {
  const StoredVoxels& s = v.image.voxels;
  const bool swap = s.big_endian != kHostIsBigEndian;
  const bool scale = !(s.slope == 1.0 && s.intercept == 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    In x;
    std::memcpy(&x, src + i * sizeof(In), sizeof(In));
    if (swap) x = byte_swapped(x);
    if constexpr (std::is_integral_v<In>) {
      if (!scale) {
        bool bad = x > static_cast<In>(
                           std::min<std::uint64_t>(kMaxLabelValue, std::numeric_limits<In>::max()));
        if constexpr (std::is_signed_v<In>) bad = bad || x < 0;
        if (bad) throw_not_label(v, first + i, static_cast<double>(x));
        dst[i] = static_cast<std::uint16_t>(x);
        continue;
      }
    }
    const double d = static_cast<double>(x) * s.slope + s.intercept;
    if (!(d >= 0.0 && d <= kMaxLabelValue && d == std::floor(d))) throw_not_label(v, first + i, d);
    dst[i] = static_cast<std::uint16_t>(d);
  }
}

void convert(const std::uint8_t* src, std::size_t n, const LabelVolume& v, std::uint64_t first,
             std::uint16_t* dst) {
  switch (v.image.voxels.type) {
    case ScalarType::u8:
      return to_labels<std::uint8_t>(src, n, v, first, dst);
    case ScalarType::i8:
      return to_labels<std::int8_t>(src, n, v, first, dst);
    case ScalarType::u16:
      return to_labels<std::uint16_t>(src, n, v, first, dst);
    case ScalarType::i16:
      return to_labels<std::int16_t>(src, n, v, first, dst);
    case ScalarType::u32:
      return to_labels<std::uint32_t>(src, n, v, first, dst);
    case ScalarType::i32:
      return to_labels<std::int32_t>(src, n, v, first, dst);
    case ScalarType::u64:
      return to_labels<std::uint64_t>(src, n, v, first, dst);
    case ScalarType::i64:
      return to_labels<std::int64_t>(src, n, v, first, dst);
    case ScalarType::f32:
      return to_labels<float>(src, n, v, first, dst);
    case ScalarType::f64:
      return to_labels<double>(src, n, v, first, dst);
  }
}

// Reads the file's values in order, a slab of slices at a time, as labels.
class SlabReader {
 public:
  SlabReader(const LabelVolume& v, std::uint64_t start, std::uint64_t need)
      : v_(v),
        element_(scalar_size(v.image.voxels.type)),
        need_(need),
        reader_(v.image.voxels.path, start, v.image.voxels.compression),
        chunk_(kChunkBytes / element_ * element_) {
    const StoredVoxels& s = v.image.voxels;
    if (!s.at_end_of_file && s.skip > 0 && reader_.skip(s.skip) < s.skip) throw_short(v, need, 0);
  }

  // The next `count` values into `dst`.
  void read(std::size_t count, std::uint16_t* dst) {
    while (count > 0) {
      const std::size_t want = std::min(count, chunk_.size() / element_);
      const std::size_t got = reader_.read(chunk_.data(), want * element_);
      if (got < want * element_) throw_short(v_, need_, done_ * element_ + got);
      convert(chunk_.data(), want, v_, done_, dst);
      done_ += want;
      dst += want;
      count -= want;
    }
  }

  // After the last value, lets a compressed stream reach its end so its checksum is verified.
  void finish() {
    if (v_.image.voxels.compression == Compression::none) return;
    std::uint8_t extra[64];
    reader_.read(extra, sizeof extra);
  }

 private:
  const LabelVolume& v_;
  std::size_t element_;
  std::uint64_t need_;
  DecodedReader reader_;
  std::vector<std::uint8_t> chunk_;
  std::uint64_t done_ = 0;
};

// ---- counting and writing ----

void count_slab(const std::vector<std::uint16_t>& slab, std::size_t values, std::size_t components,
                const LabelLookup& lookup, LabelCounts& counts) {
  for (std::size_t at = 0; at < values; at += components) {
    bool labelled = false;
    for (std::size_t c = 0; c < components; ++c) {
      const std::uint16_t value = slab[at + c];
      if (value == 0) continue;
      labelled = true;
      counts.max_value = std::max<std::uint32_t>(counts.max_value, value);
      const std::int32_t cls = lookup.at(c, value);
      if (cls >= 0) {
        ++counts.in_file[static_cast<std::size_t>(cls)];
      } else if (cls == LabelLookup::kUndefined && counts.undefined++ == 0) {
        counts.undefined_component = static_cast<std::int64_t>(c);
        counts.undefined_value = value;
      }
    }
    counts.labelled_in_file += labelled ? 1 : 0;
  }
}

// The CT voxels i of a row whose label k index, base + step * i rounded, may lie in [k0, k1).
std::pair<std::int64_t, std::int64_t> row_range(double base, double step, std::int64_t k0,
                                                std::int64_t k1, std::int64_t n) {
  if (std::fabs(step) < 1e-12) {
    const std::int64_t k = nearest(base);
    return k >= k0 && k < k1 ? std::pair<std::int64_t, std::int64_t>{0, n}
                             : std::pair<std::int64_t, std::int64_t>{0, 0};
  }
  double a = (static_cast<double>(k0) - 0.5 - base) / step;
  double b = (static_cast<double>(k1) - 0.5 - base) / step;
  if (a > b) std::swap(a, b);
  const double lo = std::clamp(std::floor(a) - 1.0, 0.0, static_cast<double>(n));
  const double hi = std::clamp(std::ceil(b) + 2.0, 0.0, static_cast<double>(n));
  return {static_cast<std::int64_t>(lo), static_cast<std::int64_t>(hi)};
}

// Where a slab of label slices [k0, k1) goes on the CT.
struct SlabTarget {
  const LabelVolume& v;
  const Grid& ct;
  const IndexMap& map;
  const LabelLookup& lookup;
  std::vector<ClassTarget>& targets;  // per class, no volume until first written
  const TargetOfClass& target_of;
};

void write_voxel(const SlabTarget& t, const std::uint16_t* values, std::size_t at,
                 LabelCounts& counts) {
  for (std::size_t c = 0; c < static_cast<std::size_t>(t.v.components); ++c) {
    if (values[c] == 0) continue;
    const std::int32_t cls = t.lookup.at(c, values[c]);
    if (cls < 0) continue;
    const auto index = static_cast<std::size_t>(cls);
    if (!t.targets[index].volume) t.targets[index] = t.target_of(cls);
    const ClassTarget& target = t.targets[index];
    std::uint8_t& slot = target.volume->data[at];
    if (slot != 0 && slot != target.value && counts.overlaps++ == 0) {
      counts.overlap_at = at;
      counts.overlap_previous = slot;
      counts.overlap_class = cls;
    }
    slot = target.value;
    ++counts.on_ct[index];
  }
}

// The same lattice (label voxel = CT voxel + a whole-voxel offset): rows copied, no rounding.
void put_slab_aligned(const SlabTarget& t, const std::vector<std::uint16_t>& slab, std::int64_t k0,
                      std::int64_t k1, LabelCounts& counts) {
  const Index3& ld = t.v.image.grid.dims;
  Index3 o;
  for (int a = 0; a < 3; ++a) o[a] = static_cast<std::int64_t>(t.map.t[a]);
  const auto components = static_cast<std::size_t>(t.v.components);
  const std::int64_t i0 = std::max<std::int64_t>(0, -o[0]);
  const std::int64_t i1 = std::min(t.ct.dims[0], ld[0] - o[0]);
  const std::int64_t j0 = std::max<std::int64_t>(0, -o[1]);
  const std::int64_t j1 = std::min(t.ct.dims[1], ld[1] - o[1]);
  const std::int64_t kb = std::max<std::int64_t>(0, k0 - o[2]);
  const std::int64_t ke = std::min(t.ct.dims[2], k1 - o[2]);
  for (std::int64_t k = kb; k < ke; ++k) {
    for (std::int64_t j = j0; j < j1; ++j) {
      counts.ct_covered += static_cast<std::uint64_t>(std::max<std::int64_t>(0, i1 - i0));
      for (std::int64_t i = i0; i < i1; ++i) {
        const auto voxel =
            static_cast<std::size_t>(i + o[0] + ld[0] * (j + o[1] + ld[1] * (k + o[2] - k0)));
        write_voxel(t, slab.data() + voxel * components, t.ct.linear(i, j, k), counts);
      }
    }
  }
}

void put_slab(const SlabTarget& t, const std::vector<std::uint16_t>& slab, std::int64_t k0,
              std::int64_t k1, LabelCounts& counts) {
  if (is_aligned(t.map)) return put_slab_aligned(t, slab, k0, k1, counts);
  const Index3& ld = t.v.image.grid.dims;
  const auto& m = t.map.m;
  const auto components = static_cast<std::size_t>(t.v.components);
  for (std::int64_t k = 0; k < t.ct.dims[2]; ++k) {
    for (std::int64_t j = 0; j < t.ct.dims[1]; ++j) {
      Vec3 base;
      for (int r = 0; r < 3; ++r)
        base[r] = t.map.t[r] + m[r][1] * static_cast<double>(j) + m[r][2] * static_cast<double>(k);
      const auto [i0, i1] = row_range(base[2], m[2][0], k0, k1, t.ct.dims[0]);
      for (std::int64_t i = i0; i < i1; ++i) {
        const double x = static_cast<double>(i);
        const std::int64_t c = nearest(base[2] + m[2][0] * x);
        if (c < k0 || c >= k1) continue;
        const std::int64_t a = nearest(base[0] + m[0][0] * x);
        const std::int64_t b = nearest(base[1] + m[1][0] * x);
        if (a < 0 || b < 0 || a >= ld[0] || b >= ld[1]) continue;
        ++counts.ct_covered;
        const auto voxel = static_cast<std::size_t>(a + ld[0] * (b + ld[1] * (c - k0)));
        write_voxel(t, slab.data() + voxel * components, t.ct.linear(i, j, k), counts);
      }
    }
  }
}

}  // namespace

LabelCounts read_labels(const LabelVolume& v, const Grid& ct, const LabelLookup& lookup,
                        std::size_t classes, const TargetOfClass& target_of,
                        std::size_t slab_values) {
  const Grid& g = v.image.grid;
  validate_grid(g, v.name);
  const auto components = static_cast<std::uint64_t>(v.components);
  const std::uint64_t slice = static_cast<std::uint64_t>(g.dims[0] * g.dims[1]) * components;
  if (slice > slab_values)
    throw label_error(v, "one slice holds " + std::to_string(slice) + " values (more than " +
                             std::to_string(slab_values) + "): too large for a label map");
  const auto map = index_map(ct, g);
  if (!map) throw label_error(v, "its axes are degenerate (no world placement)");
  check_overlap(v, *map, ct);
  const std::uint64_t need = g.voxel_count() * components * scalar_size(v.image.voxels.type);
  SlabReader reader(v, check_size(v, need), need);

  LabelCounts counts;
  counts.in_file.assign(classes, 0);
  counts.on_ct.assign(classes, 0);
  counts.resampled = !is_aligned(*map);
  std::vector<ClassTarget> targets(classes);
  const SlabTarget target{v, ct, *map, lookup, targets, target_of};
  const std::int64_t per_slab =
      std::max<std::int64_t>(1, static_cast<std::int64_t>(slab_values / slice));
  std::vector<std::uint16_t> slab;
  for (std::int64_t k0 = 0; k0 < g.dims[2]; k0 += per_slab) {
    const std::int64_t k1 = std::min(g.dims[2], k0 + per_slab);
    const auto values = static_cast<std::size_t>(slice * static_cast<std::uint64_t>(k1 - k0));
    slab.resize(values);
    reader.read(values, slab.data());
    count_slab(slab, values, static_cast<std::size_t>(components), lookup, counts);
    put_slab(target, slab, k0, k1, counts);
  }
  reader.finish();
  if (counts.ct_covered == 0)
    throw InputError("labels: " + v.name +
                     " does not overlap the CT (no CT voxel's nearest label voxel is in it)");
  return counts;
}

bool same_grid(const Grid& a, const Grid& b) {
  const auto map = index_map(a, b);
  return a.dims == b.dims && map && is_aligned(*map) && map->t == Vec3{0, 0, 0};
}

std::string describe_grid(const Grid& g) {
  char text[160];
  std::snprintf(text, sizeof text, "%.4g x %.4g x %.4g mm (%lld x %lld x %lld voxels)",
                g.spacing[0], g.spacing[1], g.spacing[2], static_cast<long long>(g.dims[0]),
                static_cast<long long>(g.dims[1]), static_cast<long long>(g.dims[2]));
  return text;
}

}  // namespace palp::labels
