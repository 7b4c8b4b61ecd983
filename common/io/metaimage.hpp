// MetaImage (ITK) headers: .mha (ElementDataFile = LOCAL, data after the header) and .mhd
// (data in a file named relative to the header's directory).
//
// Keys (case-sensitive, any order, ElementDataFile last): ObjectType Image, NDims 3, DimSize,
// ElementSpacing (or ElementSize), ElementType MET_UCHAR/CHAR/SHORT/USHORT/INT/UINT/LONG/ULONG/
// LONG_LONG/ULONG_LONG/FLOAT/DOUBLE, BinaryDataByteOrderMSB / ElementByteOrderMSB,
// CompressedData (a zlib stream), HeaderSize (detached data; -1: data at the end of the file),
// Offset / Origin / Position, TransformMatrix / Rotation / Orientation. World coordinates are
// LPS already. TransformMatrix lists the direction of the i axis first, then j, then k (the
// transpose of the row-major direction matrix), as ITK's MetaImageIO writes and reads it.
#pragma once

#include <string>

#include "io/stored_image.hpp"

namespace palp {

StoredImage read_metaimage_header(const std::string& path);

}  // namespace palp
