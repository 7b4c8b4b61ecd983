// Skin deformation for rendering: the haptic loop's contacts drive a ChainMail (chainmail.hpp)
// on the voxel elements of a small region of interest (ROI) around the tool, and the render
// volume is resampled through the resulting displacement inside that ROI only. Pure: no
// rendering, no threads; palpview owns one and calls update() once per rendered frame.
//
// Data flow per update():
//   contacts in contact (x_i, p_i) -> anchors: the element nearest p_i moves by x_i - p_i
//   (their mean is -u, paper eq. 13) -> ROI box around the anchors (+ margin, grown so the
//   displacement can fade to 0 before the boundary) -> ChainMail propagate + elastic
//   relaxation, ROI boundary held at rest -> displacement d per ROI element -> deformed(v) =
//   original(v - d(v)) (trilinear, clamped to the volume) for the voxels where d may be nonzero
//   -> written into the caller's output volume; voxels the last update wrote that this one does
//   not are restored from the original.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "base/vec.hpp"
#include "deform/chainmail.hpp"

namespace palp {

struct DeformerParams {
  // The ROI: the anchors' bounding box grown by this much, and at least by what the largest
  // anchor displacement needs to fade to 0 through the links (plus the relaxation's reach).
  // That reach alone keeps the deformation inside the ROI, so any margin gives the same
  // displacements; the margin only sizes the ChainMail box (10 mm: was 20).
  double roi_margin_mm = 10.0;
  // An anchor moves at most this far (its direction kept): no tool presses deeper, and a contact
  // far from its proxy (a hostile or broken stream) must not make the ROI the whole volume.
  double max_displacement_mm = 40.0;
  // ChainMail elements are at least this large: along an axis whose voxels are finer, one element
  // spans floor(lattice_mm / spacing) voxels and the voxels between elements take the trilinear
  // interpolation of their displacements (a full-resolution CT's 0.8 mm voxels: 1.6 mm elements,
  // a quarter of the elements; voxels of 1 mm and more: one element a voxel, as before).
  double lattice_mm = 1.6;
  ChainMailParams chainmail;
};

// One contact of the haptic loop, scene frame, mm. Pass only the contacts in contact; one whose
// proxy lies outside the volume, or with a non-finite coordinate, is skipped.
struct DeformContact {
  Vec3d x{};  // the contact point (inside the skin when pressing)
  Vec3d p{};  // its proxy (on the surface, dragged by friction)
};

struct DeformResult {
  bool active = false;  // some contact deformed the volume this update
  // Voxel box [lo, hi) of `out` written this update: the voxels deformed now together with
  // those of the last update restored to the original (empty, lo == hi, when nothing changed).
  // A renderer uploads this box.
  std::array<std::int64_t, 3> lo{}, hi{};
  std::array<std::int64_t, 3> roi_lo{}, roi_hi{};  // the ChainMail box (volume voxels)
  std::int64_t elements = 0;                       // ChainMail elements in the ROI
  std::array<std::int64_t, 3> lattice{1, 1, 1};    // voxels per element along each axis
  std::int64_t anchors = 0;                        // contacts used as anchors
  Vec3d mean_anchor_displacement{};                // mean of x_i - p_i over them (= -u)
  double seconds = 0;                              // time update() took
  double solve_seconds = 0;                        // of which the ChainMail solve
  double resample_seconds = 0;  // and the restore and resampling of the written box
};

class SkinDeformer {
 public:
  // `original`: the undeformed render scalars, dims[0]*dims[1]*dims[2] values, i fastest;
  // voxel (i, j, k) at (i, j, k) * spacing (mm). Kept by copy. UsageError for bad dims,
  // spacing, a size mismatch or a negative margin.
  SkinDeformer(std::array<std::int64_t, 3> dims, std::array<double, 3> spacing,
               std::vector<float> original, DeformerParams params = {});

  // Updates `out` (same size as the original; the caller initialises it with the original
  // once) for these contacts: see the data flow at the top. No contacts: restores the last
  // written box and returns active = false. UsageError when out has the wrong size.
  // Allocates nothing once the ROI and the number of contacts have reached their largest size.
  DeformResult update(std::span<const DeformContact> contacts, std::span<float> out);

  // The displacement (mm) of the voxel (i, j, k) after the last update (0 outside the ROI).
  Vec3d displacement_at(std::int64_t i, std::int64_t j, std::int64_t k) const;

  const ChainMail& chainmail() const { return mail_; }
  const std::vector<float>& original() const { return original_; }
  std::array<std::int64_t, 3> dims() const { return dims_; }
  std::array<double, 3> spacing() const { return spacing_; }

 private:
  using Index3 = std::array<std::int64_t, 3>;
  // The anchors' box in lattice elements [lo, hi) and their largest displacement per component.
  struct AnchorBox {
    Index3 lo{}, hi{};
    std::array<double, 3> largest{};
  };
  // anchors_ from the contacts (the element nearest each proxy, moved by x - p, clamped).
  AnchorBox place_anchors(std::span<const DeformContact> contacts, DeformResult& result);
  // The ROI around the anchors in elements [elo, ehi) (roi_lo_/roi_hi_ in voxels), element size h.
  void place_roi(const AnchorBox& box, Index3& elo, Index3& ehi, std::array<double, 3>& h);
  // The ChainMail solved over the ROI; [new_lo, new_hi) the voxels it may have moved.
  void solve_around(const AnchorBox& box, DeformResult& result, Index3& new_lo, Index3& new_hi);
  // The last update's box restored, the new one resampled into `out`; result's written box.
  void rewrite(std::span<float> out, const Index3& new_lo, const Index3& new_hi,
               DeformResult& result);
  void restore(std::span<float> out, const std::array<std::int64_t, 3>& keep_lo,
               const std::array<std::int64_t, 3>& keep_hi) const;
  // The written box of `out` resampled through the displacement.
  void resample(std::span<float> out);
  // resample() on a coarser lattice: the displacement interpolated between elements.
  void resample_interpolated(std::span<float> out);
  // resample() at one element a voxel: each voxel's own displacement.
  void resample_at_elements(std::span<float> out);
  float sample(double i, double j, double k) const;
  // The displacement at voxel (i, j, k) inside the ROI: the element's, or interpolated between
  // elements on a coarser lattice.
  Vec3d lattice_displacement(std::int64_t i, std::int64_t j, std::int64_t k) const;

  std::array<std::int64_t, 3> dims_;
  std::array<double, 3> spacing_;
  std::vector<float> original_;
  DeformerParams params_;
  ChainMail mail_;
  std::vector<ChainMailAnchor> anchors_;                     // scratch, reused
  std::array<std::int64_t, 3> lattice_{1, 1, 1};             // voxels per element
  std::array<std::int64_t, 3> lattice_dims_{};               // elements spanning the volume
  std::array<std::int64_t, 3> roi_lo_{}, roi_hi_{};          // voxels (multiples of the lattice)
  std::array<std::int64_t, 3> written_lo_{}, written_hi_{};  // deformed voxels of `out`
  bool roi_active_ = false;
  // resample() scratch on a coarser lattice: a row's displacement at its elements (3 components)
  // and, per voxel along i, its two elements and fraction.
  struct Column {
    std::int64_t e0 = 0, e1 = 0;
    double f = 0;
  };
  // sample()'s constants per axis: the largest coordinate, the last cell's base voxel, the
  // stride, and the step to the next voxel (0 along an axis of one voxel).
  std::array<double, 3> sample_upper_{};
  std::array<std::int64_t, 3> sample_base_max_{}, sample_stride_{}, sample_step_{};
  std::vector<double> row_disp_;
  std::vector<Column> column_;
};

}  // namespace palp
