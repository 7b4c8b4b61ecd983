// Skin deformation for rendering (see skin_deformation.hpp for the data flow): contacts to
// ChainMail anchors, the ROI around them, the solve, and the resampling of the render volume
// through the displacement, written only where the displacement may be nonzero.
#include "deform/skin_deformation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "base/errors.hpp"

namespace palp {

namespace {

using Index3 = std::array<std::int64_t, 3>;

bool empty_box(const Index3& lo, const Index3& hi) {
  return lo[0] >= hi[0] || lo[1] >= hi[1] || lo[2] >= hi[2];
}

}  // namespace

SkinDeformer::SkinDeformer(std::array<std::int64_t, 3> dims, std::array<double, 3> spacing,
                           std::vector<float> original, DeformerParams params)
    : dims_(dims),
      spacing_(spacing),
      original_(std::move(original)),
      params_(params),
      mail_(params.chainmail) {
  for (int a = 0; a < 3; ++a) {
    if (dims[a] <= 0) throw UsageError("skin deformation: volume dimensions must be positive");
    if (!(spacing[a] > 0.0 && std::isfinite(spacing[a])))
      throw UsageError("skin deformation: spacing must be positive and finite");
  }
  if (static_cast<std::int64_t>(original_.size()) != dims[0] * dims[1] * dims[2])
    throw UsageError("skin deformation: the original volume has " +
                     std::to_string(original_.size()) + " values, not dims[0]*dims[1]*dims[2]");
  if (!(params_.roi_margin_mm >= 0.0 && std::isfinite(params_.roi_margin_mm)))
    throw UsageError("skin deformation: roi_margin_mm must be finite and non-negative");
  if (!(params_.max_displacement_mm > 0.0 && std::isfinite(params_.max_displacement_mm)))
    throw UsageError("skin deformation: max_displacement_mm must be finite and positive");
  if (!(params_.lattice_mm >= 0.0 && std::isfinite(params_.lattice_mm)))
    throw UsageError("skin deformation: lattice_mm must be finite and non-negative");
  for (int a = 0; a < 3; ++a) {
    // A relative tolerance: spacings arrive as float32 from image headers (0.8f is
    // 0.80000001 mm), and 1.6 / 0.80000001 must give 2 voxels an element, not 1.
    lattice_[a] = std::clamp<std::int64_t>(
        static_cast<std::int64_t>(std::floor(params_.lattice_mm / spacing_[a] * (1.0 + 1e-6))), 1,
        16);
    lattice_dims_[a] = (dims_[a] - 1) / lattice_[a] + 1;  // element e at voxel e * lattice
    sample_upper_[a] = static_cast<double>(dims_[a] - 1);
    sample_base_max_[a] = std::max<std::int64_t>(0, dims_[a] - 2);
  }
  sample_stride_ = {1, dims_[0], dims_[0] * dims_[1]};
  for (int a = 0; a < 3; ++a) sample_step_[a] = dims_[a] > 1 ? sample_stride_[a] : 0;
  // Room for the ChainMail of a deep, sliding press (palpview's recorded ones: up to 131 000
  // elements), allocated and touched now: the first press does not pay for it (9.3 ms, not
  // 1-5 ms, measured in palpview at 512 x 512 x 400). 2^18 elements, 10.5 MB; larger ROIs grow.
  mail_.reserve(static_cast<std::size_t>(std::min<std::int64_t>(
      lattice_dims_[0] * lattice_dims_[1] * lattice_dims_[2], std::int64_t{1} << 18)));
}

Vec3d SkinDeformer::displacement_at(std::int64_t i, std::int64_t j, std::int64_t k) const {
  if (!roi_active_) return {};
  if (i < roi_lo_[0] || j < roi_lo_[1] || k < roi_lo_[2] || i >= roi_hi_[0] || j >= roi_hi_[1] ||
      k >= roi_hi_[2])
    return {};
  return lattice_displacement(i, j, k);
}

Vec3d SkinDeformer::lattice_displacement(std::int64_t i, std::int64_t j, std::int64_t k) const {
  const std::array<std::int64_t, 3> v{i, j, k};
  const auto md = mail_.dims();
  std::array<std::int64_t, 3> e{};
  std::array<double, 3> f{};
  for (int a = 0; a < 3; ++a) {
    const std::int64_t local = v[a] - roi_lo_[a];
    e[a] = local / lattice_[a];
    f[a] = static_cast<double>(local - e[a] * lattice_[a]) / static_cast<double>(lattice_[a]);
  }
  if (lattice_ == std::array<std::int64_t, 3>{1, 1, 1}) return mail_.displacement(e[0], e[1], e[2]);
  Vec3d d{};
  for (int c = 0; c < 8; ++c) {
    const std::array<std::int64_t, 3> o{c & 1, (c >> 1) & 1, (c >> 2) & 1};
    double w = 1.0;
    std::array<std::int64_t, 3> n{};
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      w *= o[a] ? f[a] : 1.0 - f[a];
      n[a] = e[a] + o[a];
      inside = inside && n[a] < md[a];
    }
    if (w == 0.0 || !inside) continue;  // beyond the ROI: at rest
    d += mail_.displacement(n[0], n[1], n[2]) * w;
  }
  return d;
}

DeformResult SkinDeformer::update(std::span<const DeformContact> contacts, std::span<float> out) {
  const auto start = std::chrono::steady_clock::now();
  if (out.size() != original_.size())
    throw UsageError("skin deformation: the output volume has " + std::to_string(out.size()) +
                     " values, the original " + std::to_string(original_.size()));
  DeformResult result;
  result.lattice = lattice_;
  const AnchorBox box = place_anchors(contacts, result);  // anchors_, in volume elements
  Index3 new_lo{}, new_hi{};                              // the voxels deformed this update
  if (anchors_.empty()) {
    roi_active_ = false;
    mail_.reset();
  } else {
    solve_around(box, result, new_lo, new_hi);  // the ROI, the solve, what may have moved
  }
  rewrite(out, new_lo, new_hi, result);  // the last box restored, the new one resampled
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

SkinDeformer::AnchorBox SkinDeformer::place_anchors(std::span<const DeformContact> contacts,
                                                    DeformResult& result) {
  // Anchors, in volume voxels for now: the element nearest each proxy moves by x - p.
  anchors_.clear();
  AnchorBox box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = std::numeric_limits<std::int64_t>::max();
    box.hi[a] = std::numeric_limits<std::int64_t>::min();
  }
  for (const auto& contact : contacts) {
    if (!is_finite(contact.x) || !is_finite(contact.p)) continue;
    const std::array<double, 3> p{contact.p.x, contact.p.y, contact.p.z};
    Index3 element{};
    bool inside = true;
    for (int a = 0; a < 3; ++a) {  // the nearest element of the lattice
      const double index = std::round(p[a] / (spacing_[a] * static_cast<double>(lattice_[a])));
      inside = inside && index >= 0.0 && index < static_cast<double>(lattice_dims_[a]) &&
               p[a] / spacing_[a] < static_cast<double>(dims_[a]) - 0.5;
      element[a] = inside ? static_cast<std::int64_t>(index) : 0;
    }
    if (!inside) continue;
    Vec3d displacement = contact.x - contact.p;
    const double length = norm(displacement);
    if (length > params_.max_displacement_mm)
      displacement = displacement * (params_.max_displacement_mm / length);
    anchors_.push_back({element, displacement});
    result.mean_anchor_displacement += displacement;
    const std::array<double, 3> d{displacement.x, displacement.y, displacement.z};
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::min(box.lo[a], element[a]);
      box.hi[a] = std::max(box.hi[a], element[a] + 1);
      box.largest[a] = std::max(box.largest[a], std::abs(d[a]));
    }
  }
  return box;
}

void SkinDeformer::place_roi(const AnchorBox& box, Index3& elo, Index3& ehi,
                             std::array<double, 3>& h) {
  // The ROI: the margin, and at least the links the largest displacement needs to fade to
  // 0 (one more for the relaxation's reach, one more so the boundary lies beyond).
  const ChainMailParams& cm = params_.chainmail;
  const int relax_reach = cm.relax_iterations > 0 && cm.relax_rate > 0.0 ? 1 : 0;
  for (int a = 0; a < 3; ++a) {
    h[a] = spacing_[a] * static_cast<double>(lattice_[a]);
    std::int64_t reach = 0;
    for (int c = 0; c < 3; ++c) {
      const double slack =
          (c == a ? std::min(cm.max_stretch - 1.0, 1.0 - cm.min_stretch) : cm.max_shear) * h[a];
      reach = std::max(reach, static_cast<std::int64_t>(std::ceil(box.largest[c] / slack)));
    }
    const auto margin = std::max(static_cast<std::int64_t>(std::ceil(params_.roi_margin_mm / h[a])),
                                 reach + relax_reach + 1);
    elo[a] = std::max<std::int64_t>(0, box.lo[a] - margin);
    ehi[a] = std::min<std::int64_t>(lattice_dims_[a], box.hi[a] + margin);
    roi_lo_[a] = elo[a] * lattice_[a];
    roi_hi_[a] = std::min<std::int64_t>(dims_[a], (ehi[a] - 1) * lattice_[a] + 1);
  }
}

void SkinDeformer::solve_around(const AnchorBox& box, DeformResult& result, Index3& new_lo,
                                Index3& new_hi) {
  result.anchors = static_cast<std::int64_t>(anchors_.size());
  result.mean_anchor_displacement *= 1.0 / static_cast<double>(anchors_.size());
  Index3 elo{}, ehi{};  // the ROI in lattice elements
  std::array<double, 3> h{};
  place_roi(box, elo, ehi, h);
  for (auto& anchor : anchors_)
    for (int a = 0; a < 3; ++a) anchor.element[a] -= elo[a];
  // The lattice origin too: the relaxation's colours then follow the element's place in the
  // volume, not in the ROI, so the ROI's placement (margin, clipping) changes nothing.
  mail_.resize({ehi[0] - elo[0], ehi[1] - elo[1], ehi[2] - elo[2]}, h, elo);
  const auto solve_start = std::chrono::steady_clock::now();
  mail_.solve(anchors_);
  result.solve_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_start).count();
  roi_active_ = true;
  result.active = true;
  result.roi_lo = roi_lo_;
  result.roi_hi = roi_hi_;
  result.elements = (ehi[0] - elo[0]) * (ehi[1] - elo[1]) * (ehi[2] - elo[2]);
  // The voxels whose displacement may be nonzero: those next to a moved element.
  if (!empty_box(mail_.active_lo(), mail_.active_hi()))
    for (int a = 0; a < 3; ++a) {
      new_lo[a] = std::max(roi_lo_[a], (mail_.active_lo()[a] - 1) * lattice_[a] + 1 + roi_lo_[a]);
      new_hi[a] = std::min(roi_hi_[a], (mail_.active_hi()[a]) * lattice_[a] + roi_lo_[a]);
    }
}

void SkinDeformer::rewrite(std::span<float> out, const Index3& new_lo, const Index3& new_hi,
                           DeformResult& result) {
  // Restore what the last update wrote and this one does not, then write the new box.
  const auto resample_start = std::chrono::steady_clock::now();
  restore(out, new_lo, new_hi);
  const bool had_old = !empty_box(written_lo_, written_hi_);
  const bool has_new = !empty_box(new_lo, new_hi);
  for (int a = 0; a < 3; ++a) {
    if (had_old && has_new) {
      result.lo[a] = std::min(written_lo_[a], new_lo[a]);
      result.hi[a] = std::max(written_hi_[a], new_hi[a]);
    } else if (had_old) {
      result.lo[a] = written_lo_[a];
      result.hi[a] = written_hi_[a];
    } else if (has_new) {
      result.lo[a] = new_lo[a];
      result.hi[a] = new_hi[a];
    }
  }
  written_lo_ = new_lo;
  written_hi_ = new_hi;
  if (has_new) resample(out);
  result.resample_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - resample_start).count();
}

void SkinDeformer::restore(std::span<float> out, const Index3& keep_lo,
                           const Index3& keep_hi) const {
  if (empty_box(written_lo_, written_hi_)) return;
  const bool keep = !empty_box(keep_lo, keep_hi);
  for (std::int64_t k = written_lo_[2]; k < written_hi_[2]; ++k)
    for (std::int64_t j = written_lo_[1]; j < written_hi_[1]; ++j) {
      const auto row = dims_[0] * (j + dims_[1] * k);
      const float* from = original_.data() + row;
      float* to = out.data() + row;
      const bool row_kept =
          keep && j >= keep_lo[1] && j < keep_hi[1] && k >= keep_lo[2] && k < keep_hi[2];
      if (!row_kept) {
        std::copy(from + written_lo_[0], from + written_hi_[0], to + written_lo_[0]);
        continue;
      }
      // The part of the row the new box covers is rewritten by resample().
      const auto left_end = std::min(written_hi_[0], keep_lo[0]);
      if (written_lo_[0] < left_end)
        std::copy(from + written_lo_[0], from + left_end, to + written_lo_[0]);
      const auto right_begin = std::max(written_lo_[0], keep_hi[0]);
      if (right_begin < written_hi_[0])
        std::copy(from + right_begin, from + written_hi_[0], to + right_begin);
    }
}

float SkinDeformer::sample(double i, double j, double k) const {
  // Per axis: clamp into the volume, the cell's base voxel (the last cell for the far edge; 0
  // along an axis of one voxel) and the fraction; constants from the constructor.
  const double q[3] = {i, j, k};
  double frac[3];
  std::int64_t offset = 0;
  for (int a = 0; a < 3; ++a) {
    const double clamped = std::min(std::max(q[a], 0.0), sample_upper_[a]);
    const auto b = std::min(static_cast<std::int64_t>(clamped), sample_base_max_[a]);
    frac[a] = clamped - static_cast<double>(b);
    offset += b * sample_stride_[a];
  }
  const std::int64_t step_i = sample_step_[0], step_j = sample_step_[1], step_k = sample_step_[2];
  const float* v = original_.data() + offset;
  const double c00 = v[0] + frac[0] * (v[step_i] - v[0]);
  const double c10 = v[step_j] + frac[0] * (v[step_j + step_i] - v[step_j]);
  const double c01 = v[step_k] + frac[0] * (v[step_k + step_i] - v[step_k]);
  const double c11 =
      v[step_k + step_j] + frac[0] * (v[step_k + step_j + step_i] - v[step_k + step_j]);
  const double c0 = c00 + frac[1] * (c10 - c00);
  const double c1 = c01 + frac[1] * (c11 - c01);
  return static_cast<float>(c0 + frac[2] * (c1 - c0));
}

void SkinDeformer::resample(std::span<float> out) {
  if (lattice_ != std::array<std::int64_t, 3>{1, 1, 1})
    resample_interpolated(out);
  else
    resample_at_elements(out);
}

void SkinDeformer::resample_interpolated(std::span<float> out) {
  const auto md = mail_.dims();
  const double* comp[3] = {mail_.displacement_component(0).data(),
                           mail_.displacement_component(1).data(),
                           mail_.displacement_component(2).data()};
  const double inv[3] = {1.0 / spacing_[0], 1.0 / spacing_[1], 1.0 / spacing_[2]};
  // Element e and fraction f of a voxel along an axis (the last element has f = 0: e + 1 is
  // clamped, its weight 0).
  const auto split = [&](int a, std::int64_t v, std::int64_t& e0, std::int64_t& e1, double& f) {
    const std::int64_t local = v - roi_lo_[a];
    e0 = local / lattice_[a];
    e1 = std::min(e0 + 1, md[a] - 1);
    f = static_cast<double>(local - e0 * lattice_[a]) / static_cast<double>(lattice_[a]);
  };
  // The elements along i that the written box's rows interpolate between, and per voxel of
  // a row its two elements (relative to the first) and fraction: the same for every row.
  const std::int64_t e_first = (written_lo_[0] - roi_lo_[0]) / lattice_[0];
  const std::int64_t e_count =
      std::min((written_hi_[0] - 1 - roi_lo_[0]) / lattice_[0] + 1, md[0] - 1) - e_first + 1;
  const std::int64_t nx = written_hi_[0] - written_lo_[0];
  row_disp_.resize(static_cast<std::size_t>(3 * e_count));
  column_.resize(static_cast<std::size_t>(nx));
  for (std::int64_t i = written_lo_[0]; i < written_hi_[0]; ++i) {
    Column& c = column_[static_cast<std::size_t>(i - written_lo_[0])];
    split(0, i, c.e0, c.e1, c.f);
    c.e0 -= e_first;
    c.e1 -= e_first;
  }
  double* row_d[3] = {row_disp_.data(), row_disp_.data() + e_count, row_disp_.data() + 2 * e_count};
  for (std::int64_t k = written_lo_[2]; k < written_hi_[2]; ++k) {
    std::int64_t k0, k1;
    double fk;
    split(2, k, k0, k1, fk);
    for (std::int64_t j = written_lo_[1]; j < written_hi_[1]; ++j) {
      std::int64_t j0, j1;
      double fj;
      split(1, j, j0, j1, fj);
      const std::int64_t rows[4] = {md[0] * (j0 + md[1] * k0), md[0] * (j1 + md[1] * k0),
                                    md[0] * (j0 + md[1] * k1), md[0] * (j1 + md[1] * k1)};
      const double w[4] = {(1 - fj) * (1 - fk), fj * (1 - fk), (1 - fj) * fk, fj * fk};
      // The row's displacement at its elements (interpolated along j and k once a row, not
      // once a voxel), then along i per voxel.
      for (int a = 0; a < 3; ++a)
        for (std::int64_t e = 0; e < e_count; ++e) {
          const std::int64_t n = e_first + e;
          row_d[a][e] = w[0] * comp[a][rows[0] + n] + w[1] * comp[a][rows[1] + n] +
                        w[2] * comp[a][rows[2] + n] + w[3] * comp[a][rows[3] + n];
        }
      const auto row = dims_[0] * (j + dims_[1] * k);
      for (std::int64_t i = written_lo_[0]; i < written_hi_[0]; ++i) {
        const Column& c = column_[static_cast<std::size_t>(i - written_lo_[0])];
        double d[3];
        for (int a = 0; a < 3; ++a) d[a] = (1 - c.f) * row_d[a][c.e0] + c.f * row_d[a][c.e1];
        out[row + i] = d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0
                           ? original_[row + i]
                           : sample(static_cast<double>(i) - d[0] * inv[0],
                                    static_cast<double>(j) - d[1] * inv[1],
                                    static_cast<double>(k) - d[2] * inv[2]);
      }
    }
  }
}

void SkinDeformer::resample_at_elements(std::span<float> out) {
  const auto mail_dims = mail_.dims();
  const double* dx = mail_.displacement_component(0).data();
  const double* dy = mail_.displacement_component(1).data();
  const double* dz = mail_.displacement_component(2).data();
  const double inv_x = 1.0 / spacing_[0], inv_y = 1.0 / spacing_[1], inv_z = 1.0 / spacing_[2];
  for (std::int64_t k = written_lo_[2]; k < written_hi_[2]; ++k)
    for (std::int64_t j = written_lo_[1]; j < written_hi_[1]; ++j) {
      const auto row = dims_[0] * (j + dims_[1] * k);
      const auto local_row =
          mail_dims[0] * ((j - roi_lo_[1]) + mail_dims[1] * (k - roi_lo_[2])) - roi_lo_[0];
      for (std::int64_t i = written_lo_[0]; i < written_hi_[0]; ++i) {
        const auto n = local_row + i;
        if (dx[n] == 0.0 && dy[n] == 0.0 && dz[n] == 0.0) {
          out[row + i] = original_[row + i];
          continue;
        }
        out[row + i] =
            sample(static_cast<double>(i) - dx[n] * inv_x, static_cast<double>(j) - dy[n] * inv_y,
                   static_cast<double>(k) - dz[n] * inv_z);
      }
    }
}

}  // namespace palp
