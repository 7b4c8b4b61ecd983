// palp prep INPUT --out DIR: masks and signed distance maps, with a summary and stage timings.
#include <cstdio>
#include <iostream>

#include "base/parallel.hpp"
#include "base/patient_frame.hpp"
#include "cli/commands.hpp"
#include "cli_common/cli.hpp"
#include "prep/labels/label_maps.hpp"
#include "prep/prep.hpp"

namespace palp::cli {
namespace {

// The help text, with the defaults read from the parameter structs so it cannot go stale.
std::string prep_usage() {
  const SegmentationParams seg;
  const DistanceParams dist;
  const SurfaceParams surface;
  char text[8192];
  std::snprintf(text, sizeof text, R"(usage: palp prep INPUT --out DIR [options]

Segments body and bone and computes the signed distance maps the force model samples.
INPUT: a .nii/.nii.gz/.mha/.mhd/.nrrd/.nhdr file, a DICOM series directory, or phantom:NAME.
Writes body.nii.gz, bone.nii.gz, d_surf.nii.gz, d_bone.nii.gz and prep.json into DIR.
With --labels, a lab's label map of the same CT gives the bone (the union of its bone classes),
vessel.nii.gz + d_vessel.nii.gz from its arteries and veins, artery.nii.gz + d_artery.nii.gz
from its arteries alone, and <name>.nii.gz + d_<name>.nii.gz per organ or muscle (uint8 0/1,
float32 mm positive inside) on the CT's grid (docs/labels.md). Without --labels, the torso
phantom drawn with structures (phantom:torso,structures) gives its own truth the same way:
artery.nii.gz + d_artery.nii.gz and liver.nii.gz + d_liver.nii.gz (docs/prep.md).
The input is checked first: air near -1000 HU and soft tissue near 0..100 HU must be present
and the body must leave air around it. Patient directions come from the file's direction
matrix; an oblique volume (gantry tilt) is resampled onto the nearest axis-aligned frame.
What prep reads: INPUT; for a .mhd or .nhdr header also the data file it names, which may be
an absolute path or lead out of the header's directory with ../ (both are legal in these
formats: check a header from elsewhere before prepping it); for a directory, every regular file
in it and in its immediate subdirectories; with --labels, SEG (a folder: every regular file in
it). Only regular files are read (a device, FIFO or socket is refused), and nothing is allocated
for a header's sizes before the bytes behind them exist (docs/security.md).
Failed or interrupted (Ctrl-C, SIGTERM), prep removes its temporary files, and when it created
DIR, what it wrote there and DIR itself.
Options:
  --out DIR               output directory (required; created if missing)
  --no-cache              recompute even if DIR already holds the result for this input
  --band MM               clamp |distance| beyond this many mm (default %g; at most 1e6)
  --surface subvoxel|mask distances to the HU iso-surfaces inside the masks, or to the masks'
                          voxel faces (default subvoxel)
  --skin-hu HU            iso level of the skin surface for subvoxel (default %g)
  --bone-hu HU            iso level of the bone surface for subvoxel (default %g)
  --skin-projection MM    subvoxel: d_surf within MM inside the skin takes the distance to the
                          trilinear HU's own iso-surface (0: off; default three coarsest spacings)
  --map-spacing MM        on a CT coarser than MM along an axis, d_surf and d_bone lie on its grid
                          refined by a whole factor per axis to at most MM, nodes aligned
                          (default %g: the CT's own grid, as the spec's outputs; e.g. 2)
  --threads N             worker threads (default: the CPUs palp may run on, here %u)
  --body-threshold HU     voxels above this are not air (default %g)
  --min-body-part ML      drop separate parts smaller than this, except the patient (default %g)
  --max-table-thickness MM  thicker horizontal bands below the patient are kept (default %g)
  --bone-seed HU          bone region-growing seeds at or above (default %g)
  --bone-grow HU          bone grows into voxels at or above (default %g)
  --bone-levels adapt|given  adapt (default): the bone levels (--bone-seed, --bone-grow and
                          --bone-hu) move with the scan's soft-tissue peak,
                          measured inside the body, by its offset from 50 HU (at most 40 HU;
                          upward only as far as the fat peak, -100 HU nominal, moved too:
                          contrast raises organs, not fat or bone);
                          given: used as written. prep.json records both ("hu_levels")
  --min-bone-island ML    drop bone islands smaller than this (default %g)
  --labels SEG            a label map of INPUT: TotalSegmentator's total task (its multi-label
                          .nii/.nii.gz, or its folder of one <class>.nii.gz per class) or a 3D
                          Slicer segmentation (.seg.nrrd); its structures replace prep's own,
                          and prep.json records each one's source. Its bytes are in the cache key
  --labels-map totalsegmentator  read a label file that names no classes (a multi-label NIfTI
                          without TotalSegmentator's label table) as the total task's (v2)
  --vessels auto|off      auto (default): find contrast-filled vessels and heart chambers in the
                          scan, keep them out of the bone and write vessel.nii.gz and
                          d_vessel.nii.gz when there are any; prep.json records the scan's
                          contrast_phase (none, arterial, portal-venous). An organ enhancing as
                          uniformly (kidneys, spleen) is taken with them (docs/anatomy.md).
                          off: neither, contrast_phase unknown
  --not-hu-ok             prep a volume that does not look like a CT in HU (prep refuses a
                          label map, an MR or a CT saved without its rescale by default)
  -q, --quiet             print only errors
  -h, --help              show this help
)",
                dist.band_mm, surface.skin_hu, surface.bone_hu, kDefaultMapSpacingMm,
                default_thread_count(), seg.body_threshold_hu, seg.min_body_part_ml,
                seg.max_table_thickness_mm, seg.bone_seed_hu, seg.bone_grow_hu,
                seg.min_bone_island_ml);
  return text;
}

// The parameters the options ask for, checked (UsageError names the option at fault).
PrepParams prep_params(const Args& args) {
  PrepParams params;
  params.use_cache = !args.has("no-cache");
  params.not_hu_ok = args.has("not-hu-ok");
  SegmentationParams& seg = params.segmentation;
  seg.body_threshold_hu = args.number("body-threshold", seg.body_threshold_hu);
  seg.min_body_part_ml = args.number("min-body-part", seg.min_body_part_ml);
  seg.bone_seed_hu = args.number("bone-seed", seg.bone_seed_hu);
  seg.bone_grow_hu = args.number("bone-grow", seg.bone_grow_hu);
  seg.max_table_thickness_mm = args.number("max-table-thickness", seg.max_table_thickness_mm);
  seg.min_bone_island_ml = args.number("min-bone-island", seg.min_bone_island_ml);
  params.distance.band_mm = args.number("band", params.distance.band_mm);
  check_distance_band(params.distance.band_mm);
  if (const auto surface = args.get("surface")) {
    params.surface.method = parse_surface_method(*surface);
  }
  params.surface.skin_hu = args.number("skin-hu", params.surface.skin_hu);
  params.surface.bone_hu = args.number("bone-hu", params.surface.bone_hu);
  if (args.get("skin-projection")) {
    params.surface.skin_projection_mm = args.number("skin-projection", 0.0);
    if (!(params.surface.skin_projection_mm >= 0.0 && params.surface.skin_projection_mm <= 100.0))
      throw UsageError("--skin-projection must be in [0, 100] mm");
  }
  params.map_spacing_mm = args.number("map-spacing", params.map_spacing_mm);
  if (!(params.map_spacing_mm >= 0.0 && params.map_spacing_mm <= 100.0))
    throw UsageError("--map-spacing must be in [0, 100] mm");
  if (const auto levels = args.get("bone-levels")) {
    if (*levels != "adapt" && *levels != "given")
      throw UsageError("--bone-levels must be adapt or given, not '" + *levels + "'");
    params.adapt_bone_levels = *levels == "adapt";
  }
  if (const auto vessels = args.get("vessels")) {
    if (*vessels != "auto" && *vessels != "off")
      throw UsageError("--vessels must be auto or off, not '" + *vessels + "'");
    params.find_vessels = *vessels == "auto";
  }
  if (const auto labels = args.get("labels")) {
    if (labels->empty()) throw UsageError("--labels needs a label map");
    params.labels_path = *labels;
  }
  if (const auto map = args.get("labels-map")) {
    if (*map != kTotalSegmentatorMap)
      throw UsageError("--labels-map: unknown class map \"" + *map +
                       "\" (known: totalsegmentator)");
    if (params.labels_path.empty()) throw UsageError("--labels-map needs --labels SEG");
    params.labels_map = *map;
  }
  const double threads = args.number("threads", default_thread_count());
  if (threads < 1 || threads > 1024 || threads != static_cast<unsigned>(threads)) {
    throw UsageError("--threads needs a whole number from 1 to 1024");
  }
  params.distance.threads = static_cast<unsigned>(threads);
  if (seg.bone_grow_hu > seg.bone_seed_hu) {
    throw UsageError("--bone-grow must not exceed --bone-seed");
  }
  return params;
}

// Prints each stage's name as it starts and its time as it ends, on stderr.
void print_stage(const std::string& stage, bool finished, double seconds) {
  if (!finished) {
    std::fprintf(stderr, "  %-14s ...", stage.c_str());
  } else {
    std::fprintf(stderr, " %7.3f s\n", seconds);
  }
  std::fflush(stderr);
}

// The patient's orientation and the scan's HU levels (a fresh run only: the cache keeps neither).
void print_patient_and_levels(const PrepResult& r, const PrepParams& params) {
  std::printf("  patient   stored %s", r.orientation.c_str());
  if (r.reoriented)
    std::printf(", %.1f deg oblique: resampled onto the nearest axis-aligned frame (%s)",
                r.obliquity_deg, patient_frame(r.grid).orientation_code().c_str());
  std::printf("\n");
  if (!r.hu_warning.empty()) std::printf("  warning   --not-hu-ok: %s\n", r.hu_warning.c_str());
  const HuLevels& h = r.hu_levels;
  if (h.peak_found)
    std::printf("  HU        soft-tissue peak %.0f HU", h.soft_peak_hu);
  else
    std::printf("  HU        no soft-tissue peak");
  if (h.fat_found) std::printf(", fat peak %.0f HU", h.fat_peak_hu);
  if (!params.adapt_bone_levels)
    std::printf(": bone levels as given\n");
  else
    std::printf(": bone levels %+.0f HU (seed %.0f, grow %.0f, surface %.0f)\n", h.offset_hu,
                h.levels.seed_hu, h.levels.grow_hu, h.levels.iso_hu);
  if (params.adapt_bone_levels && !h.note.empty()) std::printf("            %s\n", h.note.c_str());
}

// The body and a line per structure (bone, vessel, a label map's organs and muscles) in ml.
void print_structures(const PrepResult& r, const PrepParams& params, double voxel_ml) {
  std::printf("  body      %llu voxels (%.0f ml)\n",
              static_cast<unsigned long long>(r.stats.body_voxels),
              static_cast<double>(r.stats.body_voxels) * voxel_ml);
  for (const PrepStructure& s : r.structures) {
    std::printf("  %-9s %llu voxels (%.0f ml), %s", s.name.c_str(),
                static_cast<unsigned long long>(s.voxels), static_cast<double>(s.voxels) * voxel_ml,
                s.source.c_str());
    if (s.name == "vessel" && s.source == "auto" && !r.from_cache)
      std::printf(", contrast phase %s", r.contrast_phase.c_str());
    std::printf("\n");
  }
  if (r.vessel_voxels == 0 && !r.from_cache && params.find_vessels)
    std::printf("  vessels   none found (contrast phase %s)\n", r.contrast_phase.c_str());
}

// The summary on stdout: the grids, the patient, the structures, what was removed, the cost.
void print_summary(const PrepResult& r, const PrepParams& params) {
  const Index3& d = r.grid.dims;
  const double voxel_ml = r.grid.spacing[0] * r.grid.spacing[1] * r.grid.spacing[2] / 1000.0;
  std::printf("prep %s%s\n", r.out_dir.c_str(),
              r.from_cache ? " (cached: input and parameters unchanged)" : "");
  std::printf("  grid      %lld x %lld x %lld voxels of %s mm\n", static_cast<long long>(d[0]),
              static_cast<long long>(d[1]), static_cast<long long>(d[2]),
              format_triple(r.grid.spacing).c_str());
  if (r.map_grid.dims != r.grid.dims)
    std::printf(
        "  maps      %lld x %lld x %lld nodes of %s mm (refined, --map-spacing)\n",
        static_cast<long long>(r.map_grid.dims[0]), static_cast<long long>(r.map_grid.dims[1]),
        static_cast<long long>(r.map_grid.dims[2]), format_triple(r.map_grid.spacing).c_str());
  if (!r.from_cache) print_patient_and_levels(r, params);
  print_structures(r, params, voxel_ml);
  if (!r.from_cache) {
    std::printf("  removed   %llu voxels that are not the patient (table, pad, cables)\n",
                static_cast<unsigned long long>(r.stats.removed_non_patient_voxels));
  }
  std::printf("  total     %.3f s, peak memory %.0f MiB, %u threads\n", r.total_seconds,
              static_cast<double>(r.peak_rss_bytes) / 1048576.0, params.distance.threads);
}

}  // namespace

int cmd_prep(const Arguments& argv) {
  const Args args(
      argv, {"help", "no-cache", "quiet", "not-hu-ok"},
      {"out", "band", "threads", "body-threshold", "min-body-part", "bone-seed", "bone-grow",
       "min-bone-island", "max-table-thickness", "surface", "skin-hu", "bone-hu", "bone-levels",
       "skin-projection", "map-spacing", "vessels", "labels", "labels-map"});
  if (args.has("help")) {
    std::cout << prep_usage();
    return 0;
  }
  if (args.positional().size() != 1) throw UsageError("prep needs one INPUT");
  const auto out = args.get("out");
  if (!out) throw UsageError("prep needs --out DIR");
  const PrepParams params = prep_params(args);
  const bool quiet = args.has("quiet");

  const std::string& input = args.positional()[0];
  if (!quiet) std::fprintf(stderr, "palp prep: %s -> %s\n", input.c_str(), out->c_str());
  PrepProgress progress;
  if (!quiet) progress = print_stage;
  const PrepResult r = run_prep(input, *out, params, progress);
  if (!quiet) print_summary(r, params);
  return 0;
}

}  // namespace palp::cli
