// palp phantom NAME --out FILE: writes a synthetic CT in HU.
#include <cstdio>
#include <iostream>

#include "base/patient_frame.hpp"
#include "cli/cli.hpp"
#include "cli/commands.hpp"
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
                                an arm and a CT table with pad and cable
Options:
  --out FILE            output file (required)
  --dims NXxNYxNZ       grid size in voxels (default: the phantom's own)
  --spacing SXxSYxSZ    voxel size in mm (default: the phantom's own)
  --orientation CODE    store the voxels in another axis order, the same patient in the same
                        place: three letters naming where each index axis grows toward, e.g.
                        RAS (NIfTI's canonical order) or LPS (DICOM's; torso and sphere default)
  -h, --help            show this help
)";

}  // namespace

int cmd_phantom(const Arguments& argv) {
  const Args args(argv, {"help"}, {"out", "dims", "spacing", "orientation"});
  if (args.has("help")) {
    std::cout << kPhantomUsage;
    return 0;
  }
  if (args.positional().size() != 1)
    throw UsageError("phantom needs one NAME (cube, sphere, torso)");
  const auto out = args.get("out");
  if (!out) throw UsageError("phantom needs --out FILE");
  PhantomOptions options;
  if (const auto dims = args.get("dims")) options.dims = parse_triple<std::int64_t>(*dims, "dims");
  if (const auto spacing = args.get("spacing"))
    options.spacing = parse_triple<double>(*spacing, "spacing");
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
