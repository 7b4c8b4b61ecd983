// Marrow filling by votes of the three orthogonal slice planes (see bone_marrow.hpp).
//
// Experts label whole bones: cortex, cancellous bone and marrow, whose HU (fatty marrow near
// 0 HU in older patients) overlaps soft tissue's, so no level tells marrow from the spinal canal's
// CSF and fat. Shape does: marrow is enclosed by cortex in every plane through it, the canal only
// in axial slices (in coronal and sagittal ones it runs the length of the spine, opening between
// the laminae, at the foramina and across the discs). A voxel is filled when at least two planes
// call it enclosed. The same 3x3 closing that bridges a cortex thinner than a voxel also adds the
// partial-volume rim of thin bone (ribs at 3 mm), where two planes agree.
#include "prep/bone/bone_marrow.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "base/parallel.hpp"
#include "prep/segment/components.hpp"
#include "prep/segment/slice_planes.hpp"

namespace palp::segmentation {
namespace {

// 3-wide dilation (or erosion) of a 0/1 image of nu x nv, along rows or along columns. Outside the
// image counts as 0 when dilating and as 1 when eroding, so a closing contains its input.
void widen_rows(const std::uint8_t* in, std::uint8_t* out, std::int64_t nu, std::int64_t nv,
                bool dilate) {
  for (std::int64_t v = 0; v < nv; ++v) {
    const std::uint8_t* a = in + v * nu;
    std::uint8_t* o = out + v * nu;
    if (nu == 1) {
      o[0] = a[0];
      continue;
    }
    if (dilate) {
      o[0] = a[0] | a[1];
      for (std::int64_t u = 1; u + 1 < nu; ++u) o[u] = a[u - 1] | a[u] | a[u + 1];
      o[nu - 1] = a[nu - 2] | a[nu - 1];
    } else {
      o[0] = a[0] & a[1];
      for (std::int64_t u = 1; u + 1 < nu; ++u) o[u] = a[u - 1] & a[u] & a[u + 1];
      o[nu - 1] = a[nu - 2] & a[nu - 1];
    }
  }
}

void widen_columns(const std::uint8_t* in, std::uint8_t* out, std::int64_t nu, std::int64_t nv,
                   bool dilate) {
  for (std::int64_t v = 0; v < nv; ++v) {
    const std::uint8_t* mid = in + v * nu;
    std::uint8_t* o = out + v * nu;
    std::copy(mid, mid + nu, o);
    for (const std::int64_t w : {v - 1, v + 1}) {
      if (w < 0 || w >= nv) continue;
      const std::uint8_t* other = in + w * nu;
      if (dilate) {
        for (std::int64_t u = 0; u < nu; ++u) o[u] |= other[u];
      } else {
        for (std::int64_t u = 0; u < nu; ++u) o[u] &= other[u];
      }
    }
  }
}

// A 3x3 closing of s.cells into s.closed, or 3x1 (along u only) when across_rows is false.
void close_plane(PlaneScratch& s, std::int64_t nu, std::int64_t nv, bool across_rows) {
  s.tmp.resize(s.cells.size());
  s.closed.resize(s.cells.size());
  if (!across_rows) {
    widen_rows(s.cells.data(), s.tmp.data(), nu, nv, true);
    widen_rows(s.tmp.data(), s.closed.data(), nu, nv, false);
    return;
  }
  widen_rows(s.cells.data(), s.tmp.data(), nu, nv, true);
  widen_columns(s.tmp.data(), s.closed.data(), nu, nv, true);
  widen_rows(s.closed.data(), s.tmp.data(), nu, nv, false);
  widen_columns(s.tmp.data(), s.closed.data(), nu, nv, false);
}

// The box [u0, u1] x [v0, v1] of a plane that holds its nonzero voxels plus a margin; false if
// the plane has none.
struct Box2 {
  std::int64_t u0, u1, v0, v1;
};

bool nonzero_box(const Plane& p, const std::uint8_t* mask, std::int64_t margin, Box2& box) {
  box = {p.nu, -1, p.nv, -1};
  for (std::int64_t v = 0; v < p.nv; ++v) {
    std::int64_t first = -1, last = -1;
    if (p.su == 1) {
      const std::uint8_t* row = mask + p.at(0, v);
      first = next_byte(row, 0, p.nu, true);
      if (first == p.nu) continue;
      last = first;
      for (std::int64_t u = next_byte(row, first, p.nu, true); u < p.nu;
           u = next_byte(row, u + 1, p.nu, true))
        last = u;
    } else {
      for (std::int64_t u = 0; u < p.nu; ++u) {
        if (!mask[p.at(u, v)]) continue;
        if (first < 0) first = u;
        last = u;
      }
      if (first < 0) continue;
    }
    box = {std::min(box.u0, first), std::max(box.u1, last), std::min(box.v0, v), v};
  }
  if (box.u1 < 0) return false;
  box = {std::max<std::int64_t>(0, box.u0 - margin), std::min(p.nu - 1, box.u1 + margin),
         std::max<std::int64_t>(0, box.v0 - margin), std::min(p.nv - 1, box.v1 + margin)};
  return true;
}

// One plane's votes, worked on a copy of the bone's box: +1 for each voxel of a hole of the
// closed bone (at most max_hole_mm2) and for each voxel the closing adds. An axial plane is closed
// 3x3 and its edges open a hole. A coronal or sagittal plane (rows = slices) is closed along its
// rows only, so no gap between slices is bridged (a disc or an interlaminar space two thick slices
// high stays open), and its first and last rows (the scan's first and last slices) do not open a
// hole: there the scan cuts a bone, whose marrow runs on beyond it.
// The bone is read through `p` and the votes written through `target`, the same (u, v) in the
// original volume (they differ when the plane was read from a transposed copy).
void vote_plane(const Plane& p, const std::uint8_t* bone, const Plane& target, bool axial,
                double max_hole_mm2, std::uint8_t* votes, PlaneScratch& s) {
  Box2 box{};
  if (!nonzero_box(p, bone, 2, box)) return;
  const std::int64_t nu = box.u1 - box.u0 + 1, nv = box.v1 - box.v0 + 1;
  const auto at = [&](std::int64_t u, std::int64_t v) { return p.at(box.u0 + u, box.v0 + v); };
  const auto vote_at = [&](std::int64_t u, std::int64_t v) {
    return target.at(box.u0 + u, box.v0 + v);
  };
  s.cells.resize(static_cast<std::size_t>(nu * nv));
  for (std::int64_t v = 0; v < nv; ++v)
    for (std::int64_t u = 0; u < nu; ++u) s.cells[u + nu * v] = bone[at(u, v)] != 0;
  close_plane(s, nu, nv, axial);
  for (std::size_t c = 0; c < s.cells.size(); ++c)
    if (s.closed[c] && !s.cells[c])
      ++votes[vote_at(static_cast<std::int64_t>(c) % nu, static_cast<std::int64_t>(c) / nu)];
  const Plane local{nu, nv, 0, 1, nu, p.u_mm, p.v_mm};
  label_plane_background(local, s.closed.data(), s);
  // Per region: -1 if it reaches an edge that opens it (the sides, and the first or last row
  // unless it is the scan's end in a coronal or sagittal plane), else its widest run along u.
  s.counts.assign(s.flags.size(), 0);
  const bool first_opens = axial || box.v0 > 0, last_opens = axial || box.v1 < p.nv - 1;
  for (std::int64_t v = 0; v < nv; ++v)
    for (std::int64_t r = s.runs.row_start[v]; r < s.runs.row_start[v + 1]; ++r) {
      const Run& run = s.runs.runs[r];
      auto& c = s.counts[s.sets.find(r)];
      if (run.begin == 0 || run.end == nu || (v == 0 && first_opens) || (v == nv - 1 && last_opens))
        c = -1;
      else if (c >= 0)
        c = std::max(c, run.end - run.begin);
    }
  // Size: an axial hole holds at most max_hole_mm2 (a marrow cavity's cross-section). In coronal
  // and sagittal planes a long bone's cavity runs along the slices as far as the scan does, so
  // only its width across them is bounded, by the side of a square of that area.
  const double max_pixels = max_hole_mm2 / (p.u_mm * p.v_mm);
  const double max_width = std::sqrt(max_hole_mm2) / p.u_mm;
  const auto fits = [&](std::int64_t root) {
    return axial ? static_cast<double>(s.area[root]) <= max_pixels
                 : static_cast<double>(s.counts[root]) <= max_width;
  };
  for (std::int64_t v = 0; v < nv; ++v)
    for (std::int64_t r = s.runs.row_start[v]; r < s.runs.row_start[v + 1]; ++r) {
      const std::int64_t root = s.sets.find(r);
      if (s.counts[root] < 0 || !fits(root)) continue;
      for (std::int64_t u = s.runs.runs[r].begin; u < s.runs.runs[r].end; ++u)
        ++votes[vote_at(u, v)];
    }
}

// Votes of `count` planes: read_plane(s) reads plane s from `bone_data`, target_plane(s) is where
// its votes go in `votes`.
template <class ReadPlane, class TargetPlane>
void vote_planes(std::int64_t count, ReadPlane read_plane, TargetPlane target_plane, bool axial,
                 const std::uint8_t* bone_data, double max_hole_mm2, Mask& votes) {
  parallel_for_chunks(count, 2, [&](std::int64_t s0, std::int64_t s1) {
    PlaneScratch scratch;
    for (std::int64_t s = s0; s < s1; ++s)
      vote_plane(read_plane(s), bone_data, target_plane(s), axial, max_hole_mm2, votes.data.data(),
                 scratch);
  });
}

std::int64_t axis_stride(const Grid& g, int axis) {
  return axis == 0 ? 1 : axis == 1 ? g.dims[0] : g.dims[0] * g.dims[1];
}

// The bone with the lateral axis slowest, then the slice axis, the posterior axis fastest: a
// sagittal plane becomes contiguous (read in place, its rows are strided twice over and cost ten
// times the other planes on a 512 x 512 x 400 CT). Copied in blocks so reads and writes both run.
std::vector<std::uint8_t> sagittal_major(const Mask& bone, const PatientAxes& axes) {
  const Grid& g = bone.grid;
  const std::int64_t nl = g.dims[axes.lateral], ns = g.dims[axes.slice],
                     np = g.dims[axes.posterior];
  const std::int64_t sl = axis_stride(g, axes.lateral), ss = axis_stride(g, axes.slice),
                     sp = axis_stride(g, axes.posterior);
  std::vector<std::uint8_t> out(bone.data.size());
  constexpr std::int64_t kBlock = 32;
  parallel_for_chunks(ns, 2, [&](std::int64_t s0, std::int64_t s1) {
    for (std::int64_t s = s0; s < s1; ++s)
      for (std::int64_t p0 = 0; p0 < np; p0 += kBlock)
        for (std::int64_t l0 = 0; l0 < nl; l0 += kBlock) {
          const std::int64_t p1 = std::min(np, p0 + kBlock), l1 = std::min(nl, l0 + kBlock);
          if (sl == 1 && p1 - p0 == kBlock && l1 - l0 == kBlock) {
            // A whole block with the lateral axis along the rows: 8x8 byte transposes, the same
            // bytes to the same places as the loop below.
            for (std::int64_t p = p0; p < p1; p += 8)
              for (std::int64_t l = l0; l < l1; l += 8)
                transpose_bytes_8x8(bone.data.data() + l + p * sp + s * ss, sp,
                                    out.data() + (l * ns + s) * np + p, ns * np);
            continue;
          }
          for (std::int64_t l = l0; l < l1; ++l)
            for (std::int64_t p = p0; p < p1; ++p)
              out[static_cast<std::size_t>((l * ns + s) * np + p)] =
                  bone.data[static_cast<std::size_t>(l * sl + p * sp + s * ss)];
        }
  });
  return out;
}

}  // namespace

void fill_marrow_by_votes(const PatientAxes& axes, const SegmentationParams& params, Mask& bone) {
  const Grid& g = bone.grid;
  Mask votes(g, 0, "bone marrow votes");
  const double max_hole = params.bone_max_hole_mm2;
  const auto axial = [&](std::int64_t s) { return axial_plane(g, axes, s); };
  const auto coronal = [&](std::int64_t s) { return coronal_plane(g, axes, s); };
  vote_planes(g.dims[axes.slice], axial, axial, true, bone.data.data(), max_hole, votes);
  vote_planes(g.dims[axes.posterior], coronal, coronal, false, bone.data.data(), max_hole, votes);
  check_allocation(g, 1, "bone marrow votes (sagittal copy)");
  const std::vector<std::uint8_t> sagittal_bone = sagittal_major(bone, axes);
  const std::int64_t np = g.dims[axes.posterior], ns = g.dims[axes.slice];
  const auto sagittal_copy = [&](std::int64_t s) {
    return Plane{np, ns, s * np * ns, 1, np, g.spacing[axes.posterior], g.spacing[axes.slice]};
  };
  const auto sagittal = [&](std::int64_t s) { return sagittal_plane(g, axes, s); };
  vote_planes(g.dims[axes.lateral], sagittal_copy, sagittal, false, sagittal_bone.data(), max_hole,
              votes);
  const auto needed = static_cast<std::uint8_t>(params.bone_marrow_votes);
  for_each_nonzero(votes, [&](std::size_t n) {
    if (votes.data[n] >= needed) bone.data[n] = 1;
  });
}

}  // namespace palp::segmentation
