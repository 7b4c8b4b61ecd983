// The trunk phantom (phantom.hpp): the CT table, the body wall, the organs and vessels as painted
// layers over which the skeleton (phantom_trunk_skeleton.cpp) is painted, and the slice-by-slice
// drawing with partial-volume blending, noise, the truth masks and the bones' labels.
#include <algorithm>
#include <array>
#include <cmath>
#include <variant>
#include <vector>

#include "base/parallel.hpp"
#include "io/phantom_torso_anatomy.hpp"
#include "io/phantom_trunk_anatomy.hpp"

namespace palp::phantom_detail {
namespace trunk {
namespace {

void add_table(std::vector<TrunkLayer>& layers) {
  layers.push_back(make_layer(Box{-kInfinity, kInfinity, kPadTop + 20.0, kPadTop + 29.0}, 300.0,
                              Tissue::kEquipment));  // carbon board across the whole width
  layers.push_back(make_layer(Box{-190.0, 190.0, kPadTop, kPadTop + 20.0}, -100.0,
                              Tissue::kEquipment));  // gel pad under the back
}

void add_body_wall(std::vector<TrunkLayer>& layers) {
  layers.push_back(make_layer(Loft{0.0}, 30.0, Tissue::kPatient));            // skin
  layers.push_back(make_layer(Loft{2.0}, -100.0, Tissue::kPatient));          // fat
  layers.push_back(make_layer(Loft{14.0}, 50.0, Tissue::kPatient));           // muscle
  layers.push_back(make_layer(Loft{26.0}, kSoftTissueHu, Tissue::kPatient));  // cavity
}

void add_organs(std::vector<TrunkLayer>& layers, const TorsoLevels& levels) {
  // Lungs' bases in the lower thorax (the right dome higher, over the liver), through the top.
  layers.push_back(
      make_layer(Ellipsoid{{-70.0, -5.0, 400.0}, {45.0, 42.0, 160.0}}, -850.0, Tissue::kPatient));
  layers.push_back(
      make_layer(Ellipsoid{{70.0, -5.0, 385.0}, {45.0, 42.0, 160.0}}, -850.0, Tissue::kPatient));
  // The liver under the right lower ribs, the kidneys behind, bowel gas in the abdomen.
  layers.push_back(make_layer(Ellipsoid{{-55.0, -20.0, 175.0}, {72.0, 62.0, 70.0}}, levels.liver,
                              Tissue::kLiver));
  for (double s : {-1.0, 1.0}) {
    layers.push_back(
        make_layer(Ellipsoid{{s * 60.0, 30.0, s < 0.0 ? 85.0 : 100.0}, {26.0, 18.0, 50.0}},
                   levels.kidney, Tissue::kPatient));
  }
  constexpr std::array<std::array<double, 6>, 3> kGas{
      {{30, -60, 40, 20, 12, 15}, {-35, -55, -10, 16, 10, 12}, {45, -50, -60, 14, 10, 12}}};
  for (const auto& g : kGas) {
    layers.push_back(
        make_layer(Ellipsoid{{g[0], g[1], g[2]}, {g[3], g[4], g[5]}}, kAirHu, Tissue::kPatient));
  }
}

// The aorta in front of the spine down to its bifurcation on L4's body, the common iliac
// arteries, and each side's external iliac and common femoral artery (under the inguinal ligament
// at the mid-inguinal point, 15 mm under the skin) into the thigh; the femoral veins beside the
// arteries toward the midline, and the inferior vena cava right of the aorta.
void add_vessels(std::vector<TrunkLayer>& layers, const TorsoLevels& levels) {
  const PelvisGeometry& p = pelvis();
  const double bifurcation_z = 12.0;
  layers.push_back(make_layer(EllipticCylinder{-22.0, -26.0, 11.0, 9.0, bifurcation_z, kInfinity},
                              levels.ivc_upper, vessel_tissue(false, levels.ivc_upper)));
  for (int n = 0; n < 2; ++n) {
    const double s = n == 0 ? -1.0 : 1.0;
    const auto& a = p.femoral_artery[static_cast<std::size_t>(n)];
    for (std::size_t m = 2; m + 1 < a.size(); ++m) {
      const Vec3d medial{-s * 13.0, 2.0, 0.0};
      layers.push_back(make_layer(Tube{to_array(a[m] + medial), to_array(a[m + 1] + medial), 5.5},
                                  levels.ivc_lower, vessel_tissue(false, levels.ivc_lower)));
    }
  }
  const Tissue artery = vessel_tissue(true, levels.artery);
  const Vec3d aorta_end{12.0, -24.0, bifurcation_z};
  layers.push_back(make_layer(EllipticCylinder{12.0, -24.0, 11.0, 11.0, bifurcation_z, kInfinity},
                              levels.artery, artery));
  for (int n = 0; n < 2; ++n) {
    const auto& a = p.femoral_artery[static_cast<std::size_t>(n)];
    layers.push_back(
        make_layer(Tube{to_array(aorta_end), to_array(a[0]), 6.5}, levels.artery, artery));
    for (std::size_t m = 1; m < a.size(); ++m)
      layers.push_back(make_layer(Tube{to_array(a[m - 1]), to_array(a[m]), kArteryRadius},
                                  levels.artery, artery));
  }
}

std::vector<TrunkLayer> trunk_layers(const PhantomOptions& options) {
  const TorsoLevels levels = torso_levels(options);
  std::vector<TrunkLayer> layers;
  add_table(layers);
  add_body_wall(layers);
  add_organs(layers, levels);
  add_vessels(layers, levels);
  add_skeleton(layers);
  return layers;
}

void paint_row(const std::vector<const TrunkLayer*>& active, const RowContext& row,
               const AnatomyFrame& frame, RowBuffers& buf) {
  std::fill(buf.hu.begin(), buf.hu.end(), kAirHu);
  std::fill(buf.tissue.begin(), buf.tissue.end(), Tissue::kOutside);
  std::fill(buf.label.begin(), buf.label.end(), std::uint8_t{0});
  for (const TrunkLayer* layer : active) {
    std::visit(
        [&](const auto& s) {
          paint_shape_row(s, layer->hu, layer->tissue, layer->label, row, frame, buf);
        },
        layer->shape);
  }
}

}  // namespace

AnatomyFrame trunk_frame(const Grid& grid) {
  AnatomyFrame f{grid_centre(grid), fit_scale(grid, kReferenceFov, 2), grid.spacing};
  const double pad_top = f.centre[1] + kPadTop * f.scale;
  const double snapped = (std::round(pad_top / grid.spacing[1] - 0.5) + 0.5) * grid.spacing[1];
  f.centre[1] += snapped - pad_top;
  return f;
}

}  // namespace trunk

CtVolume draw_trunk(const Grid& grid, const PhantomOptions& options, PhantomTruth* truth) {
  using namespace trunk;
  const AnatomyFrame frame = trunk_frame(grid);
  const std::vector<TrunkLayer> layers = trunk_layers(options);
  CtVolume ct(grid, 0, "trunk phantom");
  if (truth) {
    *truth = empty_truth(grid, "trunk truth");
    truth->bone_label = Mask(grid, 0, "trunk bone labels");
  }
  const std::int64_t nx = grid.dims[0], ny = grid.dims[1];
  parallel_for_chunks(grid.dims[2], 1, [&](std::int64_t k_begin, std::int64_t k_end) {
    RowBuffers buf{std::vector<double>(nx), std::vector<Tissue>(nx), std::vector<std::uint8_t>(nx)};
    std::vector<const TrunkLayer*> active;
    for (std::int64_t k = k_begin; k < k_end; ++k) {
      const double z = frame.coord(2, k), margin = frame.voxel_size()[2];
      active.clear();
      for (const TrunkLayer& layer : layers)
        if (z >= layer.z_min - margin && z <= layer.z_max + margin) active.push_back(&layer);
      for (std::int64_t j = 0; j < ny; ++j) {
        const RowContext row{frame.coord(1, j), z, frame.voxel_size()};
        paint_row(active, row, frame, buf);
        const std::size_t base = grid.linear(0, j, k);
        for (std::int64_t i = 0; i < nx; ++i)
          ct.data[base + i] = to_hu(buf.hu[i] + noise_hu(i, j, k));
        if (!truth) continue;
        write_truth(buf, base, *truth);
        std::copy(buf.label.begin(), buf.label.end(), truth->bone_label.data.begin() + base);
      }
    }
  });
  return ct;
}

}  // namespace palp::phantom_detail
