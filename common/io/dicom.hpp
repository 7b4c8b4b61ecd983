// DICOM CT series directories, decoded through GDCM (uncompressed, JPEG lossless, JPEG-LS,
// JPEG 2000, RLE: whatever the installed GDCM decodes).
//
// The directory (and its immediate subdirectories) must hold exactly one series of single-frame
// greyscale images. Files without the DICOM Part 10 preamble ("DICM" at byte 128) and DICOM files
// without an image are skipped; a DICOM file that cannot be parsed or decoded is an error naming
// it. GDCM runs in a child process, so a malformed file that makes it abort is reported as an
// InputError instead of ending palp. Rows/Columns, PixelSpacing and
// ImageOrientationPatient must agree across slices, and the slice positions projected on the
// normal (row direction x column direction) must be evenly spaced (within 1% or 0.01 mm) without
// duplicates. HU = stored * RescaleSlope + RescaleIntercept per slice, rounded and saturated to
// int16.
//
// Scene frame: i = column, j = row, k = slice in increasing position along the normal; spacing
// = (column spacing, row spacing, slice gap). World (LPS): origin = the first slice's
// ImagePositionPatient; direction columns = row direction, column direction, normal.
#pragma once

#include <string>

#include "base/volume.hpp"

namespace palp {

CtVolume read_dicom_series(const std::string& directory);

}  // namespace palp
