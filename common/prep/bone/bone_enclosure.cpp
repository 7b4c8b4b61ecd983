// Marrow between cortices (see bone_enclosure.hpp).
//
// Per line direction, two sweeps over the bone's bounding box (grown by the radius): the forward
// sweep stores each voxel's steps back to the nearest bone along the line (capped), the backward
// sweep the steps ahead, and a voxel with both within the radius gets the line's vote. One byte
// per voxel for the distances, visited in an order where the neighbour behind is done, so the
// rows vectorise; the 13 directions are split between two workers with their own buffers.
#include "prep/bone/bone_enclosure.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "base/errors.hpp"
#include "base/parallel.hpp"
#include "prep/segment/components.hpp"

namespace palp::segmentation {
namespace {

struct Line {
  std::array<std::int64_t, 3> step{};  // voxel step along each axis, -1, 0 or 1
  std::int64_t reach = 0;              // steps within the radius
  std::int64_t far_reach = 0;          // steps within the plate radius
};

// The 13 lines through a voxel of the 3x3x3 neighbourhood (one of each opposite pair).
std::vector<Line> lines_within(const Grid& g, double radius_mm, double far_mm) {
  std::vector<Line> lines;
  for (std::int64_t dz = -1; dz <= 1; ++dz)
    for (std::int64_t dy = -1; dy <= 1; ++dy)
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const std::int64_t first = dx != 0 ? dx : dy != 0 ? dy : dz;
        if (first <= 0) continue;
        const double len = std::sqrt(std::pow(static_cast<double>(dx) * g.spacing[0], 2) +
                                     std::pow(static_cast<double>(dy) * g.spacing[1], 2) +
                                     std::pow(static_cast<double>(dz) * g.spacing[2], 2));
        const auto reach = static_cast<std::int64_t>(std::floor(radius_mm / len));
        const auto far = static_cast<std::int64_t>(std::floor(far_mm / len));
        lines.push_back(
            {{dx, dy, dz}, std::min<std::int64_t>(reach, 250), std::min<std::int64_t>(far, 250)});
      }
  return lines;
}

// The bone's bounding box grown by the radius, and the box's cells: 0 outside the body, 1 bone,
// 2 a body voxel outside the bone (a candidate).
struct Box {
  std::array<std::int64_t, 3> lo{}, dims{};
  std::array<std::array<bool, 2>, 3> cut{};  // leaving the box there leaves the scan's end slices
  std::vector<std::uint8_t> cells;
  std::size_t at(std::int64_t i, std::int64_t j, std::int64_t k) const {
    return static_cast<std::size_t>(i + dims[0] * (j + dims[1] * k));
  }
};

bool bone_box(const Mask& bone, const Mask& body, const std::array<std::int64_t, 3>& margin,
              int slice, Box& box) {
  const Grid& g = bone.grid;
  // Each slice's box of bone, written only by the thread that visits that slice (the slices are
  // shared out whole), then merged here: one shared box updated by every thread lost updates, so
  // the box, and with it the enclosure, changed from run to run (ThreadSanitizer).
  using SliceBox = std::array<std::int64_t, 6>;  // lo i, j, k; hi i, j, k
  std::vector<SliceBox> per_slice(static_cast<std::size_t>(g.dims[2]),
                                  SliceBox{g.dims[0], g.dims[1], g.dims[2], -1, -1, -1});
  for_each_nonzero(bone, [&](std::size_t n) {
    const auto nx = static_cast<std::size_t>(g.dims[0]), ny = static_cast<std::size_t>(g.dims[1]);
    const std::array<std::int64_t, 3> q = {static_cast<std::int64_t>(n % nx),
                                           static_cast<std::int64_t>((n / nx) % ny),
                                           static_cast<std::int64_t>(n / (nx * ny))};
    SliceBox& b = per_slice[static_cast<std::size_t>(q[2])];
    for (int a = 0; a < 3; ++a) b[a] = std::min(b[a], q[a]), b[3 + a] = std::max(b[3 + a], q[a]);
  });
  std::array<std::int64_t, 3> lo = g.dims, hi = {-1, -1, -1};
  for (const SliceBox& b : per_slice)
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], b[a]), hi[a] = std::max(hi[a], b[3 + a]);
  if (hi[0] < 0) return false;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = std::max<std::int64_t>(0, lo[a] - margin[a] - 1);
    const std::int64_t top = std::min(g.dims[a] - 1, hi[a] + margin[a] + 1);
    box.dims[a] = top - box.lo[a] + 1;
    box.cut[a] = {a == slice && box.lo[a] == 0, a == slice && top == g.dims[a] - 1};
  }
  box.cells.assign(static_cast<std::size_t>(box.dims[0] * box.dims[1] * box.dims[2]), 0);
  for (std::int64_t k = 0; k < box.dims[2]; ++k)
    for (std::int64_t j = 0; j < box.dims[1]; ++j) {
      const std::size_t src = g.linear(box.lo[0], box.lo[1] + j, box.lo[2] + k);
      std::uint8_t* out = box.cells.data() + box.at(0, j, k);
      for (std::int64_t i = 0; i < box.dims[0]; ++i)
        out[i] =
            bone.data[src + static_cast<std::size_t>(i)]
                ? 1
                : static_cast<std::uint8_t>(body.data[src + static_cast<std::size_t>(i)] ? 2 : 0);
    }
  return true;
}

constexpr std::uint8_t kFar = 255;

inline std::uint8_t next_step(std::uint8_t from) {  // one step further, saturating at kFar
  return static_cast<std::uint8_t>(std::min<unsigned>(from, kFar - 1u) + 1u);
}

// One worker's votes for a voxel, over its share of the lines (at most 7): bits 0-3 count the
// lines that bone brackets within the radius, bits 4-7 those within the plate radius, where the
// line across the slices (the body axis) counts 9: the high nibble is the line count, plus 8 when
// the axis line is among them (at most 6 + 9).
using Votes = std::uint8_t;
constexpr Votes kFarVote = 16, kAxisVote = 9 * 16;

// One sweep along `step`: dist[q] = 0 on bone, else 1 + dist[q - step], saturating at kFar;
// leaving the box across a cut end counts as bone just outside. With `votes`, the backward sweep
// (step negated) adds a vote where the candidate's forward value (still in dist) and its backward
// value are both within `reach`, and `far_vote` where both are within `far_reach`, before
// overwriting it.
void sweep(const Box& box, const std::array<std::int64_t, 3>& step, std::uint8_t reach,
           std::uint8_t far_reach, Votes far_vote, std::uint8_t* dist, Votes* votes) {
  const std::int64_t nx = box.dims[0], ny = box.dims[1], nz = box.dims[2], dx = step[0];
  const auto exit_value = [&](int axis, std::int64_t from) {  // `from`: the coordinate left to
    return box.cut[axis][from < 0 ? 0 : 1] ? std::uint8_t{1} : kFar;
  };
  const auto put = [&](std::uint8_t* d, const std::uint8_t* cell, Votes* v, std::int64_t i,
                       std::uint8_t from) {
    const std::uint8_t value = cell[i] == 1 ? std::uint8_t{0} : next_step(from);
    if (v) {
      const bool candidate = cell[i] == 2;
      const bool near = candidate & (d[i] <= reach) & (value <= reach);
      const bool far = candidate & (d[i] <= far_reach) & (value <= far_reach);
      v[i] = static_cast<Votes>(v[i] + near + far * far_vote);
    }
    d[i] = value;
  };
  for (std::int64_t kk = 0; kk < nz; ++kk) {
    const std::int64_t k = step[2] < 0 ? nz - 1 - kk : kk;
    for (std::int64_t jj = 0; jj < ny; ++jj) {
      const std::int64_t j = step[1] < 0 ? ny - 1 - jj : jj;
      const std::int64_t pk = k - step[2], pj = j - step[1];
      std::uint8_t row_exit = 0;  // 0: the row behind is inside the box
      if (pk < 0 || pk >= nz) row_exit = exit_value(2, pk);
      if (pj < 0 || pj >= ny)
        row_exit = row_exit ? std::min(row_exit, exit_value(1, pj)) : exit_value(1, pj);
      const std::size_t row = box.at(0, j, k);
      const std::uint8_t* cell = box.cells.data() + row;
      std::uint8_t* d = dist + row;
      Votes* v = votes ? votes + row : nullptr;
      // The voxel whose neighbour behind lies beyond the row's end (none when dx == 0).
      const std::int64_t edge = dx > 0 ? 0 : nx - 1;
      const std::int64_t lo = dx > 0 ? 1 : 0, hi = dx < 0 ? nx - 1 : nx;  // the others
      if (dx != 0) {
        const std::uint8_t x_exit = exit_value(0, edge - dx);
        put(d, cell, v, edge, row_exit ? std::min(row_exit, x_exit) : x_exit);
      }
      if (row_exit) {
        for (std::int64_t i = lo; i < hi; ++i) put(d, cell, v, i, row_exit);
      } else if (step[1] == 0 && step[2] == 0) {  // along the row: each voxel needs the last
        if (dx > 0)
          for (std::int64_t i = lo; i < hi; ++i) put(d, cell, v, i, d[i - 1]);
        else
          for (std::int64_t i = hi - 1; i >= lo; --i) put(d, cell, v, i, d[i + 1]);
      } else {  // the row behind is done: independent voxels
        const std::uint8_t* behind = dist + box.at(0, pj, pk) - dx;
        for (std::int64_t i = lo; i < hi; ++i) put(d, cell, v, i, behind[i]);
      }
    }
  }
}

// The rule over `bone`: the votes of every line, then the voxels they fill.
void enclosure_pass(const PatientAxes& axes, const std::vector<Line>& lines,
                    const std::array<std::int64_t, 3>& margin, int needed, bool plates,
                    const Mask& body, Mask& bone) {
  const Grid& g = bone.grid;
  Box box;
  if (!bone_box(bone, body, margin, axes.slice, box)) return;
  // Two workers, each with its own distances and votes for its share of the lines.
  constexpr std::int64_t kWorkers = 2;
  static_assert((13 + kWorkers - 1) / kWorkers <= 7, "a worker's line counts must fit 3 bits");
  std::vector<std::vector<Votes>> votes(kWorkers);
  const auto count = static_cast<std::int64_t>(lines.size());
  parallel_for_chunks(kWorkers, 1, [&](std::int64_t w0, std::int64_t w1) {
    for (std::int64_t w = w0; w < w1; ++w) {
      std::vector<std::uint8_t> dist(box.cells.size());
      std::vector<Votes>& v = votes[static_cast<std::size_t>(w)];
      v.assign(box.cells.size(), 0);
      for (std::int64_t l = w; l < count; l += kWorkers) {
        const Line& line = lines[static_cast<std::size_t>(l)];
        const auto reach = static_cast<std::uint8_t>(line.reach);
        const auto far_reach = static_cast<std::uint8_t>(line.far_reach);
        bool across_slices = true;  // the line along the body axis
        for (int a = 0; a < 3; ++a) across_slices &= (line.step[a] != 0) == (a == axes.slice);
        const Votes far_vote = across_slices ? kAxisVote : kFarVote;
        sweep(box, line.step, reach, far_reach, far_vote, dist.data(), nullptr);
        const std::array<std::int64_t, 3> back = {-line.step[0], -line.step[1], -line.step[2]};
        sweep(box, back, reach, far_reach, far_vote, dist.data(), v.data());
      }
    }
  });
  // Within the radius along `needed` lines; or, a plate between cortices farther apart, within
  // the plate radius along as many lines and along the body axis (the spinal canal, a tube open
  // along the axis, is not bracketed along it; nor is a foramen's channel across the slices).
  // Row by row, in parallel over the box's slices (each writes only its own rows of the bone);
  // every byte of the row is written, 1 or its own value, so the loop vectorises.
  parallel_for_chunks(box.dims[2], 4, [&](std::int64_t k0, std::int64_t k1) {
    for (std::int64_t k = k0; k < k1; ++k)
      for (std::int64_t j = 0; j < box.dims[1]; ++j) {
        const Votes* w0 = votes[0].data() + box.at(0, j, k);
        const Votes* w1 = votes[1].data() + box.at(0, j, k);
        std::uint8_t* out = bone.data.data() + g.linear(box.lo[0], box.lo[1] + j, box.lo[2] + k);
        for (std::int64_t i = 0; i < box.dims[0]; ++i) {
          const unsigned v0 = w0[i], v1 = w1[i];
          const bool near = static_cast<int>((v0 & 15u) + (v1 & 15u)) >= needed;
          const unsigned f0 = v0 >> 4, f1 = v1 >> 4;  // line counts in bits 0-2, the axis in bit 3
          const bool plate =
              plates && static_cast<int>((f0 & 7u) + (f1 & 7u)) >= needed && ((f0 | f1) & 8u) != 0;
          out[i] = near || plate ? std::uint8_t{1} : out[i];
        }
      }
  });
}

}  // namespace

void fill_between_cortices(const PatientAxes& axes, const SegmentationParams& params,
                           const Mask& body, Mask& bone) {
  const int needed = params.bone_enclosure_directions;
  if (needed <= 0) return;
  const Grid& g = bone.grid;
  // The plate radius reaches at least as far as the radius (0: no plate rule).
  const double far_mm = std::max(params.bone_enclosure_radius_mm, params.bone_plate_radius_mm);
  const bool plates = params.bone_plate_radius_mm > params.bone_enclosure_radius_mm;
  const std::vector<Line> lines = lines_within(g, params.bone_enclosure_radius_mm, far_mm);
  std::array<std::int64_t, 3> margin{};
  for (int a = 0; a < 3; ++a)
    margin[a] = static_cast<std::int64_t>(std::floor(far_mm / g.spacing[a]));
  check_allocation(g, 5, "bone enclosure");
  enclosure_pass(axes, lines, margin, needed, plates, body, bone);
}

}  // namespace palp::segmentation
