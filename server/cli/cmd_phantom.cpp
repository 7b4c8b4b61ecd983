// palp phantom NAME --out FILE: writes a synthetic CT in HU.
#include <cstdio>
#include <iostream>

#include "base/patient_frame.hpp"
#include "cli/commands.hpp"
#include "cli_common/cli.hpp"
#include "io/ct_io.hpp"
#include "io/phantom.hpp"
#include "prep/reorient.hpp"

namespace palp::cli {
namespace {

constexpr const char* kPhantomUsage = R"(usage: palp phantom NAME --out FILE [options]

Writes a synthetic CT in Hounsfield units as NIfTI (.nii or .nii.gz).
  NAME                  cube    soft-tissue block (90 mm a side, flat faces, no bone), 1 mm grid
                        sphere  soft-tissue ball of analytic radius, 1 mm grid
                        torso   the default scene: body, ribs, liver, spine, lungs, bowel gas,
                                a 250 HU aorta, kidneys, an arm and a CT table with pad and cable
                        trunk   T8 to the proximal femora with known landmarks: vertebrae
                                T8-L5 and the sacrum, ribs 8-12, iliac crests, femoral
                                arteries, liver, a CT table (its truth: io/phantom_trunk.hpp)
Options:
  --out FILE            output file (required)
  --dims NXxNYxNZ       grid size in voxels (default: the phantom's own); x and y scale the
                        anatomy down to fit, z never does (--dims 384x256x20: a thin slab)
  --spacing SXxSYxSZ    voxel size in mm (default: the phantom's own)
Torso (and trunk: contrast, aorta-hu, structures; in a CT input also orient=CODE, e.g.
phantom:trunk,orient=RAS; phantom:torso,contrast=arterial,arms=2,metal,structures):
  --contrast PHASE      none, arterial or portal-venous: the vessel tree (aorta to its
                        bifurcation, coeliac, SMA, renal and iliac arteries, IVC, renal and
                        portal veins) at that phase's HU instead of the lone 250 HU aorta
  --aorta-hu N          the aorta's and its branches' HU (with the arterial phase's veins
                        unless --contrast says otherwise)
  --arms N              0, 1 (default) or 2 arms beside the torso (with the vessel tree each
                        has its brachial artery, 1 mm from the humerus: cut off by both ends)
  --level MM            the anatomy's z at the field of view's centre (default 0; -200..200):
                        where along the body the scan lies (torso only)
  --metal               a pair of pedicle screws (3500 HU) in a vertebra, with streaks
  --dissection          the aorta dissected: a 14 mm true lumen at its HU, the false lumen at
                        soft-tissue HU filling the rest of it, in periaortic fat (torso only)
  --structures          what a finger feels besides bone: the femoral arteries (and veins) in
                        the groin 15 mm under the skin, joined to the aorta by the iliac
                        arteries, and the liver's inferior edge below the right costal margin;
                        the truth masks (artery, liver) prep writes as artery.nii.gz, liver.nii.gz
  --orientation CODE    store the voxels in another axis order, the same patient in the same
                        place: three letters naming where each index axis grows toward, e.g.
                        RAS (NIfTI's canonical order) or LPS (DICOM's; torso, trunk and
                        sphere default)
  -h, --help            show this help
)";

}  // namespace

int cmd_phantom(const Arguments& argv) {
  const Args args(
      argv, {"help", "metal", "structures", "dissection"},
      {"out", "dims", "spacing", "orientation", "contrast", "aorta-hu", "arms", "level"});
  if (args.has("help")) {
    std::cout << kPhantomUsage;
    return 0;
  }
  if (args.positional().size() != 1)
    throw UsageError("phantom needs one NAME (cube, sphere, torso, trunk)");
  const auto out = args.get("out");
  if (!out) throw UsageError("phantom needs --out FILE");
  PhantomOptions options;
  if (const auto dims = args.get("dims")) options.dims = parse_triple<std::int64_t>(*dims, "dims");
  if (const auto spacing = args.get("spacing"))
    options.spacing = parse_triple<double>(*spacing, "spacing");
  for (const char* key : {"contrast", "aorta-hu", "arms", "level"})
    if (const auto value = args.get(key)) set_phantom_option(options, key, *value);
  if (args.has("metal")) options.metal = true;
  if (args.has("structures")) options.structures = true;
  if (args.has("dissection")) options.dissection = true;
  CtVolume ct = make_phantom(args.positional()[0], options);
  if (const auto code = args.get("orientation")) ct = reorder_axes(ct, *code);
  write_nifti(*out, ct);
  const Index3& d = ct.grid.dims;
  std::printf("wrote %s: %s phantom, %lld x %lld x %lld voxels of %s mm, stored %s\n", out->c_str(),
              args.positional()[0].c_str(), static_cast<long long>(d[0]),
              static_cast<long long>(d[1]), static_cast<long long>(d[2]),
              format_triple(ct.grid.spacing).c_str(),
              patient_frame(ct.grid).orientation_code().c_str());
  return 0;
}

}  // namespace palp::cli
