// What tests that write DICOM CT series with GDCM share: string tags, int16 pixel data, and the
// tags that make a dataset one CT slice of a series (tests/common/io/dicom_test.cpp,
// tests/common/prep/shared_ct_dicom_test.cpp).
#pragma once

#include <gdcmAttribute.h>
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmImage.h>
#include <gdcmUIDGenerator.h>

#include <cstdint>
#include <string>
#include <vector>

namespace palp::testing {

template <std::uint16_t G, std::uint16_t E>
void set_dicom_string(gdcm::DataSet& ds, const std::string& value) {
  gdcm::Attribute<G, E> attribute;
  attribute.SetValue(value.c_str());
  ds.Replace(attribute.GetAsDataElement());
}

// The image's pixel data: stored int16 values, row by row.
inline void set_int16_pixels(gdcm::Image& image, const std::vector<std::int16_t>& pixels) {
  gdcm::DataElement pixel_data(gdcm::Tag(0x7fe0, 0x0010));
  pixel_data.SetByteValue(reinterpret_cast<const char*>(pixels.data()),
                          static_cast<std::uint32_t>(pixels.size() * sizeof(std::int16_t)));
  image.SetDataElement(pixel_data);
}

// CT Image Storage, a fresh SOP instance UID, modality CT, the study and series UIDs and the
// instance number.
inline void set_ct_slice_identity(gdcm::DataSet& ds, const std::string& study,
                                  const std::string& series, int instance) {
  gdcm::UIDGenerator uid;
  set_dicom_string<0x0008, 0x0016>(ds, "1.2.840.10008.5.1.4.1.1.2");
  set_dicom_string<0x0008, 0x0018>(ds, uid.Generate());
  set_dicom_string<0x0008, 0x0060>(ds, "CT");
  set_dicom_string<0x0020, 0x000d>(ds, study);
  set_dicom_string<0x0020, 0x000e>(ds, series);
  gdcm::Attribute<0x0020, 0x0013> number{instance};
  ds.Replace(number.GetAsDataElement());
}

}  // namespace palp::testing
