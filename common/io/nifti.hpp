// NIfTI-1 single-file images (.nii, .nii.gz): header parsing and writing.
//
// Reading accepts both byte orders, datatypes uint8/int8/int16/uint16/int32/uint32/int64/uint64/
// float32/float64, scl_slope/scl_inter (slope 0 or non-finite: no scaling), dim[0] 1..7 with
// dimensions past the third equal to 1. World placement: sform when sform_code > 0, else the
// qform quaternion when qform_code > 0, else the scaled identity; NIfTI's RAS is converted to
// palp's LPS metadata (x and y negated). Spacing is |pixdim[1..3]|.
//
// Writing: native byte order, vox_offset 352, qform (code 1, scanner) and sform (code 1) from
// Grid::world converted back to RAS, xyzt_units mm; gzip'd when the path ends in .gz.
#pragma once

#include <string>

#include "io/gzip.hpp"
#include "io/stored_image.hpp"

namespace palp {

// Parses the header of a .nii / .nii.gz file; the voxels are read by ct_io (read_ct etc.).
StoredImage read_nifti_header(const std::string& path);

// Writes `voxels` (grid.voxel_count() values of `type`: u8, i16 or f32, native byte order).
// cal_min / cal_max are stored as the display range.
void write_nifti_file(const std::string& path, const Grid& grid, ScalarType type, ByteSpan voxels,
                      double cal_min, double cal_max);

// True when the path ends in ".gz" (any case).
bool has_gz_suffix(const std::string& path);

}  // namespace palp
