// Label files for the tests of common/prep/labels: uint8 NIfTI through palp's own writer, and
// TotalSegmentator's label table added as TotalSegmentator writes it (totalsegmentator/
// nifti_ext_header.py, add_label_map_to_nifti: one NIfTI-1 header extension, ecode 0, holding
// CaretExtension XML with a <Label Key="id" ...><![CDATA[name]]></Label> per class).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "io/gzip.hpp"
#include "io/nifti.hpp"
#include "support/io_test_util.hpp"

namespace palp::testing {

inline Grid label_grid(Index3 dims, Vec3 spacing = {1.5, 1.5, 1.5}, Vec3 origin = {-4, 7, 100}) {
  Grid g;
  g.dims = dims;
  g.spacing = spacing;
  g.world.origin = origin;
  return g;
}

// A uint8 NIfTI of `values` (gzip'd when the path ends in .gz).
inline void write_label_nifti(const std::string& path, const Grid& grid,
                              const std::vector<std::uint8_t>& values) {
  write_nifti_file(path, grid, ScalarType::u8, ByteSpan(values.data(), values.size()), 0, 255);
}

// The XML TotalSegmentator writes for its label table.
inline std::string caret_label_table(const std::vector<std::pair<int, std::string>>& labels) {
  std::string xml =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?> <CaretExtension>  <Date><![CDATA[2013-07-14T05:"
      "45:09]]></Date>   <VolumeInformation Index=\"0\">   <LabelTable>\n";
  for (const auto& [id, name] : labels)
    xml += "<Label Key=\"" + std::to_string(id) +
           "\" Red=\"1.0\" Green=\"0.0\" Blue=\"0.0\" Alpha=\"1\"><![CDATA[" + name +
           "]]></Label>\n";
  xml +=
      "\n  </LabelTable>  <StudyMetaDataLinkSet>  </StudyMetaDataLinkSet>  <VolumeType><![CDATA["
      "Label]]></VolumeType>   </VolumeInformation></CaretExtension>\n              ";
  return xml;
}

// A uint8 NIfTI whose header extension holds `xml` (esize a multiple of 16, as nibabel pads it;
// vox_offset moved past the extension).
inline void write_label_nifti_with_extension(const std::string& path, const Grid& grid,
                                             const std::vector<std::uint8_t>& values,
                                             const std::string& xml) {
  const std::string plain = path + ".plain.nii";
  write_label_nifti(plain, grid, values);
  std::vector<std::uint8_t> bytes = read_bytes(plain);
  std::remove(plain.c_str());
  const std::int32_t esize = static_cast<std::int32_t>((8 + xml.size() + 15) / 16 * 16);
  std::vector<std::uint8_t> extension(static_cast<std::size_t>(esize), 0);
  const std::int32_t ecode = 0;
  std::memcpy(extension.data(), &esize, 4);
  std::memcpy(extension.data() + 4, &ecode, 4);
  std::memcpy(extension.data() + 8, xml.data(), xml.size());
  const float vox_offset = 352.0f + static_cast<float>(esize);
  std::memcpy(bytes.data() + 108, &vox_offset, 4);
  bytes[348] = 1;  // the extender: extensions follow
  bytes.insert(bytes.begin() + 352, extension.begin(), extension.end());
  if (path.size() > 3 && path.compare(path.size() - 3, 3, ".gz") == 0) {
    const std::vector<std::uint8_t> gz = gzip_compress(ByteSpan(bytes.data(), bytes.size()));
    write_bytes(path, gz);
  } else {
    write_bytes(path, bytes);
  }
}

}  // namespace palp::testing
