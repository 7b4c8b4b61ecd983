// Tests for metaimage.hpp through read_ct: .mha (LOCAL) and .mhd (detached) files written here
// by hand — byte orders, element types, zlib CompressedData, origin and TransformMatrix order —
// and bad headers.
#include "io/metaimage.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include "base/errors.hpp"
#include "io/ct_io.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

using testing::kSampleHu;
using testing::payload;
using testing::TempDir;
using testing::write_bytes;
using testing::write_header_and_data;
using testing::write_text;

std::vector<std::uint8_t> zlib_compress(const std::vector<std::uint8_t>& data) {
  uLongf size = compressBound(data.size());
  std::vector<std::uint8_t> out(size);
  EXPECT_EQ(compress2(out.data(), &size, data.data(), data.size(), 6), Z_OK);
  out.resize(size);
  return out;
}

const std::string kBasicHeader =
    "ObjectType = Image\n"
    "NDims = 3\n"
    "BinaryData = True\n"
    "BinaryDataByteOrderMSB = False\n"
    "CompressedData = False\n"
    "TransformMatrix = 0 1 0 -1 0 0 0 0 1\n"
    "Offset = -10.5 20 300.25\n"
    "CenterOfRotation = 0 0 0\n"
    "AnatomicalOrientation = RAI\n"
    "ElementSpacing = 0.5 0.75 2\n"
    "DimSize = 3 2 2\n"
    "ElementType = MET_SHORT\n"
    "ElementDataFile = LOCAL\n";

TEST(MetaImage, LocalRawWithTransformMatrixInItkOrder) {
  TempDir dir;
  write_header_and_data(dir.file("a.mha"), kBasicHeader, payload(kSampleHu));
  const CtVolume ct = read_ct(dir.file("a.mha"));
  EXPECT_EQ(ct.grid.dims, (Index3{3, 2, 2}));
  EXPECT_EQ(ct.grid.spacing, (Vec3{0.5, 0.75, 2}));
  EXPECT_EQ(ct.grid.world.origin, (Vec3{-10.5, 20, 300.25}));
  // TransformMatrix lists the i axis direction (0,1,0) first, then j (-1,0,0), then k.
  EXPECT_EQ(ct.grid.world.direction, (std::array<double, 9>{0, -1, 0, 1, 0, 0, 0, 0, 1}));
  EXPECT_EQ(ct.data, kSampleHu);
}

TEST(MetaImage, DetachedBigEndianWithAlternativeKeysAndHeaderSize) {
  TempDir dir;
  std::filesystem::create_directories(dir.path() / "data");
  auto data = std::vector<std::uint8_t>(16, 0xee);  // HeaderSize bytes to skip
  const auto values = payload(kSampleHu, true);
  data.insert(data.end(), values.begin(), values.end());
  write_bytes(dir.file("data/a.raw"), data);
  write_text(dir.file("a.mhd"),
             "NDims = 3\n"
             "DimSize = 3 2 2\n"
             "ElementByteOrderMSB = True\n"
             "ElementSize = 1 1 3\n"
             "Origin = 1 2 3\n"
             "Orientation = 1 0 0 0 1 0 0 0 1\n"
             "ElementType = MET_SHORT\n"
             "HeaderSize = 16\n"
             "ElementDataFile = data/a.raw\n");
  const CtVolume ct = read_ct(dir.file("a.mhd"));
  EXPECT_EQ(ct.grid.spacing, (Vec3{1, 1, 3}));
  EXPECT_EQ(ct.grid.world.origin, (Vec3{1, 2, 3}));
  EXPECT_EQ(ct.data, kSampleHu);

  // HeaderSize = -1: the voxels are the last bytes of the file.
  write_text(dir.file("end.mhd"),
             "NDims = 3\nDimSize = 3 2 2\nElementType = MET_SHORT\nBinaryDataByteOrderMSB = True\n"
             "HeaderSize = -1\nElementDataFile = data/a.raw\n");
  EXPECT_EQ(read_ct(dir.file("end.mhd")).data, kSampleHu);
}

TEST(MetaImage, CompressedDataLocalAndDetached) {
  TempDir dir;
  const auto packed = zlib_compress(payload(kSampleHu));
  std::string header = kBasicHeader;
  header.replace(header.find("CompressedData = False"), 22,
                 "CompressedData = True\nCompressedDataSize = " + std::to_string(packed.size()));
  write_header_and_data(dir.file("z.mha"), header, packed);
  EXPECT_EQ(read_ct(dir.file("z.mha")).data, kSampleHu);

  write_bytes(dir.file("z.zraw"), packed);
  write_text(dir.file("z.mhd"),
             "ObjectType = Image\nNDims = 3\nDimSize = 3 2 2\nElementType = MET_SHORT\n"
             "CompressedData = True\nElementDataFile = z.zraw\n");
  EXPECT_EQ(read_ct(dir.file("z.mhd")).data, kSampleHu);
}

TEST(MetaImage, ElementTypes) {
  TempDir dir;
  const std::string prefix = "NDims = 3\nDimSize = 2 2 1\n";
  write_header_and_data(dir.file("u8.mha"),
                        prefix + "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n",
                        payload(std::vector<std::uint8_t>{0, 1, 200, 255}));
  EXPECT_EQ(read_ct(dir.file("u8.mha")).data, (std::vector<std::int16_t>{0, 1, 200, 255}));
  write_header_and_data(dir.file("f.mha"),
                        prefix + "ElementType = MET_FLOAT\nElementDataFile = LOCAL\n",
                        payload(std::vector<float>{-1000.4f, 0.5f, 99.5f, 1e6f}));
  EXPECT_EQ(read_ct(dir.file("f.mha")).data, (std::vector<std::int16_t>{-1000, 1, 100, 32767}));
  write_header_and_data(dir.file("d.mha"),
                        prefix + "ElementType = MET_DOUBLE\nElementDataFile = LOCAL\n",
                        payload(std::vector<double>{-2.5, 2.5, 7, -7}));
  EXPECT_EQ(read_ct(dir.file("d.mha")).data, (std::vector<std::int16_t>{-3, 3, 7, -7}));
  write_header_and_data(dir.file("u16.mha"),
                        prefix + "ElementType = MET_USHORT\nElementDataFile = LOCAL\n",
                        payload(std::vector<std::uint16_t>{0, 1, 40000, 3}));
  EXPECT_EQ(read_ct(dir.file("u16.mha")).data, (std::vector<std::int16_t>{0, 1, 32767, 3}));
  write_header_and_data(dir.file("i32.mha"),
                        prefix + "ElementType = MET_INT\nElementDataFile = LOCAL\n",
                        payload(std::vector<std::int32_t>{-1024, 1, -40000, 3}));
  EXPECT_EQ(read_ct(dir.file("i32.mha")).data, (std::vector<std::int16_t>{-1024, 1, -32768, 3}));
  write_header_and_data(dir.file("i8.mha"),
                        prefix + "ElementType = MET_CHAR\nElementDataFile = LOCAL\n",
                        payload(std::vector<std::int8_t>{-128, 1, 127, 3}));
  EXPECT_EQ(read_ct(dir.file("i8.mha")).data, (std::vector<std::int16_t>{-128, 1, 127, 3}));
  write_header_and_data(dir.file("u32.mha"),
                        prefix + "ElementType = MET_UINT\nElementDataFile = LOCAL\n",
                        payload(std::vector<std::uint32_t>{0, 1, 4000000000u, 3}));
  EXPECT_EQ(read_ct(dir.file("u32.mha")).data, (std::vector<std::int16_t>{0, 1, 32767, 3}));
}

// ---- bad input ----

std::string with(std::string header, const std::string& from, const std::string& to) {
  header.replace(header.find(from), from.size(), to);
  return header;
}

TEST(MetaImageErrors, NonNumericSpacing) {
  TempDir dir;
  write_header_and_data(
      dir.file("s.mha"),
      with(kBasicHeader, "ElementSpacing = 0.5 0.75 2", "ElementSpacing = 1 abc 2"),
      payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("s.mha")), InputError,
                    "s.mha: ElementSpacing = \"1 abc 2\" is not 3 finite numbers");
  write_header_and_data(dir.file("z.mha"),
                        with(kBasicHeader, "ElementSpacing = 0.5 0.75 2", "ElementSpacing = 1 0 2"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("z.mha")), InputError, "z.mha: spacing");
}

TEST(MetaImageErrors, DataShorterThanTheHeaderSays) {
  TempDir dir;
  auto data = payload(kSampleHu);
  data.resize(20);
  write_header_and_data(dir.file("short.mha"), kBasicHeader, data);
  EXPECT_PALP_ERROR(read_ct(dir.file("short.mha")), InputError,
                    "short.mha: header says 24 bytes of voxel data, file has 20");
}

TEST(MetaImageErrors, TruncatedCompressedData) {
  TempDir dir;
  auto packed = zlib_compress(payload(std::vector<std::int16_t>(3000, 5)));
  packed.resize(packed.size() / 2);
  write_header_and_data(dir.file("t.mha"),
                        with(with(kBasicHeader, "CompressedData = False", "CompressedData = True"),
                             "DimSize = 3 2 2", "DimSize = 30 10 10"),
                        packed);
  EXPECT_PALP_ERROR(read_ct(dir.file("t.mha")), InputError, "t.mha: truncated zlib stream");
}

TEST(MetaImageErrors, UnsupportedAndMalformedHeaders) {
  TempDir dir;
  const auto data = payload(kSampleHu);
  write_header_and_data(dir.file("t.mha"), with(kBasicHeader, "MET_SHORT", "MET_FLOAT_ARRAY"),
                        data);
  EXPECT_PALP_ERROR(read_ct(dir.file("t.mha")), InputError,
                    "ElementType MET_FLOAT_ARRAY is not supported");
  write_header_and_data(dir.file("n.mha"), with(kBasicHeader, "NDims = 3", "NDims = 2"), data);
  EXPECT_PALP_ERROR(read_ct(dir.file("n.mha")), InputError,
                    "NDims is 2 (only 3-D images are supported)");
  write_header_and_data(dir.file("d.mha"), with(kBasicHeader, "DimSize = 3 2 2", "DimSize = 3 0 2"),
                        data);
  EXPECT_PALP_ERROR(read_ct(dir.file("d.mha")), InputError, "dimensions 3x0x2 are not usable");
  write_header_and_data(dir.file("big.mha"),
                        with(kBasicHeader, "DimSize = 3 2 2", "DimSize = 16000 16000 16000"), data);
  EXPECT_PALP_ERROR(read_ct(dir.file("big.mha")), InputError, "header says 8192000000000 bytes");
  write_header_and_data(dir.file("o.mha"),
                        with(kBasicHeader, "ObjectType = Image", "ObjectType = Tube"), data);
  EXPECT_PALP_ERROR(read_ct(dir.file("o.mha")), InputError, "ObjectType is Tube, not Image");
  write_header_and_data(
      dir.file("m.mha"),
      with(kBasicHeader, "TransformMatrix = 0 1 0 -1 0 0 0 0 1", "TransformMatrix = 1 0"), data);
  EXPECT_PALP_ERROR(read_ct(dir.file("m.mha")), InputError,
                    "TransformMatrix = \"1 0\" is not 9 finite numbers");
  write_header_and_data(dir.file("e.mha"), with(kBasicHeader, "ElementDataFile = LOCAL\n", ""), {});
  EXPECT_PALP_ERROR(read_ct(dir.file("e.mha")), InputError,
                    "e.mha: MetaImage header has no ElementDataFile line");
  write_bytes(dir.file("bin.mha"), std::vector<std::uint8_t>{0x00, 0x01, 0xff, '\n', 'x'});
  EXPECT_PALP_ERROR(read_ct(dir.file("bin.mha")), InputError, "bin.mha: not a MetaImage header");
  write_text(dir.file("nodata.mhd"),
             "NDims = 3\nDimSize = 3 2 2\nElementType = MET_SHORT\nElementDataFile = nope.raw\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("nodata.mhd")), InputError,
                    "nope.raw: no such file or directory");
  write_text(dir.file("list.mhd"),
             "NDims = 3\nDimSize = 3 2 2\nElementType = MET_SHORT\nElementDataFile = LIST\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("list.mhd")), InputError, "multi-file data");
  write_header_and_data(
      dir.file("b.mha"),
      with(kBasicHeader, "BinaryDataByteOrderMSB = False", "BinaryDataByteOrderMSB = maybe"), data);
  EXPECT_PALP_ERROR(read_ct(dir.file("b.mha")), InputError, "is not True or False");
}

}  // namespace
}  // namespace palp
