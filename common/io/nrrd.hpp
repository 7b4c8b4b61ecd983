// NRRD headers: .nrrd (data attached after a blank line) and .nhdr (detached, "data file:").
//
// Magic NRRD0001..NRRD0005; fields type (every C spelling: short, int16, int16_t, signed short,
// ushort, uchar, float, double, int, ...), dimension 3, sizes, spacings or space directions,
// space origin, space (left-posterior-superior / right-anterior-superior / left-anterior-superior
// and their abbreviations, converted to LPS; scanner-xyz and 3D-*-handed kept as they are),
// encoding raw / gzip / gz, endian, byte skip (-1: raw data at the end of the file), line skip.
// Comments (#) are ignored; key:=value lines only read_nrrd_layered_header returns.
#pragma once

#include <cstdint>
#include <map>
#include <string>

#include "io/stored_image.hpp"

namespace palp {

StoredImage read_nrrd_header(const std::string& path);

// A NRRD with its key:=value pairs (NRRD's "\n" and "\\" escapes decoded; a key given twice keeps
// its last value) and, as 3D Slicer writes segmentations with overlapping layers, an optional
// leading non-spatial axis: "dimension: 4", the first kind not "domain"/"space" (or absent) and
// the first space direction "none". Its length is `components`; the values of one voxel lie next
// to each other. Otherwise as read_nrrd_header.
struct NrrdLayeredImage {
  StoredImage image;  // the grid of the three spatial axes; voxels.type is one value's type
  std::int64_t components = 1;
  std::map<std::string, std::string> key_values;
};
NrrdLayeredImage read_nrrd_layered_header(const std::string& path);

}  // namespace palp
