// NRRD headers: .nrrd (data attached after a blank line) and .nhdr (detached, "data file:").
//
// Magic NRRD0001..NRRD0005; fields type (every C spelling: short, int16, int16_t, signed short,
// ushort, uchar, float, double, int, ...), dimension 3, sizes, spacings or space directions,
// space origin, space (left-posterior-superior / right-anterior-superior / left-anterior-superior
// and their abbreviations, converted to LPS; scanner-xyz and 3D-*-handed kept as they are),
// encoding raw / gzip / gz, endian, byte skip (-1: raw data at the end of the file), line skip.
// Comments (#) and key:=value lines are ignored.
#pragma once

#include <string>

#include "io/stored_image.hpp"

namespace palp {

StoredImage read_nrrd_header(const std::string& path);

}  // namespace palp
