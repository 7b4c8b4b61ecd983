// How much of a scene's maps a brick or narrow-band store would keep (issue 21, the
// representation question): the maps are cut into B^3-voxel bricks; a brick is kept when any
// voxel of it, or of the one-voxel apron trilinear sampling and the gradient schemes read, lies
// within the distance band (|d_surf| <= band or |d_bone| <= band); every other brick would be one
// clamped constant in the brick index. Prints, per band, the bricks kept, the voxels within the
// band (a narrow band's lower bound) and the memory each store would hold against the dense maps,
// for palp's default maps (precomputed gradient, float32: bytes per voxel from the sampler) -
// an estimate: no brick sampler exists, so no tick time is measured.
//
//   study_map_bricks PREP_DIR [--brick B] [--bands 10,20,30]
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "model/field_sampler.hpp"
#include "prep/prep.hpp"

namespace {

using namespace palp;

constexpr const char* kUsage = "usage: study_map_bricks PREP_DIR [--brick B] [--bands 10,20,30]\n";

int run(int argc, char** argv) {
  if (argc < 2) throw UsageError("a prep directory");
  const std::filesystem::path dir = argv[1];
  int brick = 8;
  std::vector<double> bands = {10.0, 20.0, 30.0};
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--brick") {
      brick = std::atoi(argv[i + 1]);
    } else if (key == "--bands") {
      bands.clear();
      std::stringstream s(argv[i + 1]);
      for (std::string part; std::getline(s, part, ',');) bands.push_back(std::atof(part.c_str()));
    } else {
      throw UsageError("unknown option " + key);
    }
  }
  if (brick < 2 || brick > 64) throw UsageError("--brick 2..64");
  const DistanceMap surf = read_nifti_float((dir / kSurfaceDistanceFile).string());
  const DistanceMap bone = read_nifti_float((dir / kBoneDistanceFile).string());
  const Index3 n = surf.grid.dims;
  // bytes per voxel of palp's default maps, from a sampler on a tiny grid of the same config
  Grid tiny = surf.grid;
  tiny.dims = {2, 2, 2};
  const FieldSampler small(DistanceMap(tiny, 1.0f), DistanceMap(tiny, 1.0f),
                           {GradientScheme::PrecomputedField, Storage::Float32});
  const double per_voxel = static_cast<double>(small.bytes_per_voxel() + 4);  // + bone-beneath
  const double dense_mib = per_voxel * static_cast<double>(surf.grid.voxel_count()) / 1048576.0;
  const std::int64_t nb[3] = {(n[0] + brick - 1) / brick, (n[1] + brick - 1) / brick,
                              (n[2] + brick - 1) / brick};
  const std::int64_t bricks = nb[0] * nb[1] * nb[2];
  std::printf(
      "maps %lldx%lldx%lld, %lld bricks of %d^3; dense (precomputed float32 + "
      "bone-beneath, %.0f B/voxel): %.1f MiB\n",
      static_cast<long long>(n[0]), static_cast<long long>(n[1]), static_cast<long long>(n[2]),
      static_cast<long long>(bricks), brick, per_voxel, dense_mib);
  std::printf(
      "band_mm,bricks_kept,bricks_kept_fraction,brick_store_mib,brick_saving,"
      "voxels_in_band_fraction,narrow_band_mib,narrow_band_saving\n");
  for (const double band : bands) {
    std::vector<char> keep(static_cast<std::size_t>(bricks), 0);
    std::int64_t in_band = 0;
    for (std::int64_t k = 0; k < n[2]; ++k)
      for (std::int64_t j = 0; j < n[1]; ++j)
        for (std::int64_t i = 0; i < n[0]; ++i) {
          const float s = surf.at(i, j, k), b = bone.at(i, j, k);
          if (!(std::abs(s) <= band || std::abs(b) <= band)) continue;
          ++in_band;
          // the voxel and its apron: every brick that samples it
          for (std::int64_t dk = -1; dk <= 1; ++dk)
            for (std::int64_t dj = -1; dj <= 1; ++dj)
              for (std::int64_t di = -1; di <= 1; ++di) {
                const std::int64_t x = i + di, y = j + dj, z = k + dk;
                if (x < 0 || y < 0 || z < 0 || x >= n[0] || y >= n[1] || z >= n[2]) continue;
                keep[static_cast<std::size_t>((z / brick * nb[1] + y / brick) * nb[0] +
                                              x / brick)] = 1;
              }
        }
    std::int64_t kept = 0;
    for (char c : keep) kept += c;
    const double brick_mib = (static_cast<double>(kept) * brick * brick * brick * per_voxel +
                              static_cast<double>(bricks) * 8.0) /
                             1048576.0;
    // a narrow band: the voxels in it with their apron (x1.5, a rough allowance) and a hash
    // entry each (8 B)
    const double band_mib = static_cast<double>(in_band) * (per_voxel * 1.5 + 8.0) / 1048576.0;
    std::printf("%g,%lld,%.4f,%.1f,%.1f,%.4f,%.1f,%.1f\n", band, static_cast<long long>(kept),
                static_cast<double>(kept) / static_cast<double>(bricks), brick_mib,
                dense_mib / brick_mib,
                static_cast<double>(in_band) / static_cast<double>(surf.grid.voxel_count()),
                band_mib, dense_mib / band_mib);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const palp::UsageError& e) {
    std::fprintf(stderr, "study_map_bricks: %s\n%s", e.what(), kUsage);
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "study_map_bricks: %s\n", e.what());
    return 1;
  }
}
