// Tests for dicom_layout.hpp on files built byte by byte here: explicit VR little endian data
// sets whose elements are cut, out of order, nested too deep, too many, or whose header is too
// large; and a 3 GB sparse file walked without reading it into memory. Files GDCM writes (and
// their truncations) are walked in dicom_test.cpp.
#include "io/dicom_layout.hpp"

#include <gtest/gtest.h>

#include <filesystem>

#include "base/errors.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

using Result = DicomLayoutCheck::Result;
using testing::append;

// Preamble, "DICM" and a file meta naming explicit VR little endian.
std::vector<char> part10_head() {
  std::vector<std::uint8_t> out(128, 0);
  for (char c : std::string("DICM")) out.push_back(static_cast<std::uint8_t>(c));
  const std::string syntax("1.2.840.10008.1.2.1\0", 20);  // padded to an even length
  append<std::uint16_t>(out, 0x0002);
  append<std::uint16_t>(out, 0x0010);
  out.push_back('U');
  out.push_back('I');
  append<std::uint16_t>(out, static_cast<std::uint16_t>(syntax.size()));
  out.insert(out.end(), syntax.begin(), syntax.end());
  return {out.begin(), out.end()};
}

// Appends an explicit VR element with a short (16-bit) length and `length` zero bytes.
void short_element(std::vector<char>& out, std::uint16_t group, std::uint16_t element,
                   std::uint16_t length) {
  std::vector<std::uint8_t> bytes;
  append(bytes, group);
  append(bytes, element);
  bytes.push_back('U');
  bytes.push_back('S');
  append(bytes, length);
  bytes.resize(bytes.size() + length, 0);
  out.insert(out.end(), bytes.begin(), bytes.end());
}

// Appends an explicit VR element with a 32-bit length (OB, SQ) but no value bytes.
void long_element_header(std::vector<char>& out, std::uint16_t group, std::uint16_t element,
                         const char* vr, std::uint32_t length) {
  std::vector<std::uint8_t> bytes;
  append(bytes, group);
  append(bytes, element);
  bytes.push_back(static_cast<std::uint8_t>(vr[0]));
  bytes.push_back(static_cast<std::uint8_t>(vr[1]));
  append<std::uint16_t>(bytes, 0);
  append(bytes, length);
  out.insert(out.end(), bytes.begin(), bytes.end());
}

// Appends an item or delimiter header (always implicit: tag and 32-bit length).
void item(std::vector<char>& out, std::uint16_t element, std::uint32_t length) {
  std::vector<std::uint8_t> bytes;
  append<std::uint16_t>(bytes, 0xfffe);
  append(bytes, element);
  append(bytes, length);
  out.insert(out.end(), bytes.begin(), bytes.end());
}

TEST(DicomLayout, WalksAWholeFileAndMeasuresItsPixelData) {
  std::vector<char> file = part10_head();
  short_element(file, 0x0028, 0x0010, 2);
  short_element(file, 0x0028, 0x0011, 2);
  long_element_header(file, 0x7fe0, 0x0010, "OB", 8);
  file.resize(file.size() + 8, 0);
  DicomLayoutCheck check(file);
  EXPECT_EQ(check.run(), Result::complete);
  EXPECT_EQ(check.transfer_syntax(), "1.2.840.10008.1.2.1");
  EXPECT_TRUE(check.has_pixel_data());
  EXPECT_EQ(check.pixel_data_bytes(), 8u);
}

TEST(DicomLayout, EncapsulatedPixelDataIsTheSumOfItsItems) {
  std::vector<char> file = part10_head();
  long_element_header(file, 0x7fe0, 0x0010, "OB", 0xffffffffu);
  item(file, 0xe000, 0);  // basic offset table
  item(file, 0xe000, 100);
  file.resize(file.size() + 100, 0);
  item(file, 0xe000, 30);
  file.resize(file.size() + 30, 0);
  item(file, 0xe0dd, 0);
  DicomLayoutCheck check(file);
  EXPECT_EQ(check.run(), Result::complete);
  EXPECT_EQ(check.pixel_data_bytes(), 130u);
}

TEST(DicomLayout, ElementsOutOfTagOrderAreRefused) {
  std::vector<char> file = part10_head();
  short_element(file, 0x0028, 0x0011, 2);
  short_element(file, 0x0028, 0x0010, 2);
  DicomLayoutCheck check(file);
  EXPECT_EQ(check.run(), Result::refused);
  EXPECT_EQ(check.reason(),
            "element (0028,0010) at byte 170 does not follow (0028,0011) in tag order");
}

TEST(DicomLayout, ALengthBeyondTheFileIsATruncation) {
  std::vector<char> file = part10_head();
  long_element_header(file, 0x0009, 0x0010, "OB", 0xfffffff0u);
  file.resize(file.size() + 16, 0);
  EXPECT_EQ(DicomLayoutCheck(file).run(), Result::truncated);
}

TEST(DicomLayout, DeepNestingIsRefused) {
  std::vector<char> file = part10_head();
  for (int depth = 0; depth < 40; ++depth) {
    long_element_header(file, 0x0009, 0x1000, "SQ", 0xffffffffu);
    item(file, 0xe000, 0xffffffffu);
  }
  DicomLayoutCheck check(file);
  EXPECT_EQ(check.run(), Result::refused);
  EXPECT_EQ(check.reason(), "sequences nested more than 32 deep");
}

TEST(DicomLayout, TooManyElementsAreRefused) {
  std::vector<char> file = part10_head();
  for (std::uint32_t n = 0; n < 100001; ++n)
    short_element(file, static_cast<std::uint16_t>(0x0009 + (n >> 16)),
                  static_cast<std::uint16_t>(n & 0xffff), 0);
  DicomLayoutCheck check(file);
  EXPECT_EQ(check.run(), Result::refused);
  EXPECT_EQ(check.reason(), "more than 100000 elements");
}

TEST(DicomLayout, AHeaderOverItsLimitIsRefused) {
  std::vector<char> file = part10_head();
  long_element_header(file, 0x0009, 0x1000, "OB", 65u << 20);
  file.resize(file.size() + (65u << 20), 0);
  DicomLayoutCheck check(file);
  EXPECT_EQ(check.run(), Result::refused);
  EXPECT_EQ(check.reason(),
            "68157612 bytes besides the pixel data, more than the limit of 67108864");
}

// A 3 GB sparse file of zeros after the magic: walked through a small window, refused at its
// second element, without reading the file into memory.
TEST(DicomLayout, ASparseGigabyteFileIsNotReadIntoMemory) {
  testing::TempDir dir;
  const std::string path = dir.file("sparse.dcm");
  testing::write_bytes(path, part10_head().data(), 132);
  std::filesystem::resize_file(path, std::uint64_t{3} << 30);
  testing::reset_peak_memory();
  const std::size_t before = testing::peak_memory_bytes();
  DicomLayoutCheck check(path);
  EXPECT_EQ(check.run(), Result::refused);
  EXPECT_EQ(check.reason(),
            "element (0000,0000) at byte 140 does not follow (0000,0000) in tag order");
  EXPECT_EQ(check.file_bytes(), std::uint64_t{3} << 30);
  EXPECT_LT(testing::peak_memory_bytes(), before + (16u << 20));
}

TEST(DicomLayout, OnlyRegularFilesAreOpened) {
  EXPECT_PALP_ERROR(DicomLayoutCheck("/dev/zero"), InputError, "not a regular file");
}

}  // namespace
}  // namespace palp
