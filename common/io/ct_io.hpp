// Reading CTs and writing volumes. Formats: NIfTI-1 (.nii, .nii.gz), MetaImage (.mha, .mhd),
// NRRD (.nrrd, .nhdr), DICOM series directories (any transfer syntax GDCM decodes: uncompressed,
// JPEG lossless, JPEG 2000, RLE), and `phantom:NAME` for the built-in synthetic CTs.
//
// Every reader returns HU as int16 (rounded, saturated to the int16 range) in the scene frame of
// the spec, with the file's origin and direction kept in Grid::world (LPS). Bad input throws
// InputError (or ResourceError for sizes that cannot fit) with a one-line message naming the
// file; nothing is allocated before the header has been checked against the data size.
#pragma once

#include <string>

#include "base/volume.hpp"

namespace palp {

// Reads any supported CT input (a file, a DICOM directory, or "phantom:NAME").
CtVolume read_ct(const std::string& input);

// The file holding the voxels of a CT file: the file itself, or the detached data file its
// header names (.mhd, .nhdr). Reads only the header; throws as read_ct does for a bad one.
std::string ct_voxel_file(const std::string& path);

// Whether read_ct reads `path` as NIfTI (its name ends in .nii or .nii.gz, any case).
bool is_nifti_name(const std::string& path);

// Writes a volume as NIfTI-1 (.nii or .nii.gz, chosen by the extension), with the grid's world
// placement written back as qform and sform (RAS, as NIfTI requires).
void write_nifti(const std::string& path, const CtVolume& volume);
void write_nifti(const std::string& path, const Mask& volume);
void write_nifti(const std::string& path, const DistanceMap& volume);
// The same, with the display range (cal_min / cal_max: the smallest and largest value) known to
// the caller, which saves a pass over the voxels.
void write_nifti(const std::string& path, const DistanceMap& volume, float lo, float hi);

// Reads back a NIfTI written by palp (or any other) as float / uint8, for tests and scenes.
DistanceMap read_nifti_float(const std::string& path);
Mask read_nifti_mask(const std::string& path);

}  // namespace palp
