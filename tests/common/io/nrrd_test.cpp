// Tests for nrrd.hpp through read_ct: attached and detached files written here by hand, type
// spellings, raw and gzip encodings, byte orders, space directions / spacings and the conversion
// of named spaces to LPS, skips, and bad headers.
#include "io/nrrd.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>

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

std::string with(std::string header, const std::string& from, const std::string& to) {
  header.replace(header.find(from), from.size(), to);
  return header;
}

const std::string kHeader =
    "NRRD0004\n"
    "# Complete NRRD file format specification at:\n"
    "# http://teem.sourceforge.net/nrrd/format.html\n"
    "type: short\n"
    "dimension: 3\n"
    "space: left-posterior-superior\n"
    "sizes: 3 2 2\n"
    "space directions: (0,0.5,0) (-0.75,0,0) (0,0,2)\n"
    "kinds: domain domain domain\n"
    "endian: little\n"
    "encoding: raw\n"
    "space origin: (-10.5,20,300.25)\n"
    "ITK_InputFilterName:=NrrdImageIO\n"
    "\n";

TEST(Nrrd, AttachedRawWithSpaceDirections) {
  TempDir dir;
  write_header_and_data(dir.file("a.nrrd"), kHeader, payload(kSampleHu));
  const CtVolume ct = read_ct(dir.file("a.nrrd"));
  EXPECT_EQ(ct.grid.dims, (Index3{3, 2, 2}));
  EXPECT_EQ(ct.grid.spacing, (Vec3{0.5, 0.75, 2}));
  EXPECT_EQ(ct.grid.world.origin, (Vec3{-10.5, 20, 300.25}));
  EXPECT_EQ(ct.grid.world.direction, (std::array<double, 9>{0, -1, 0, 1, 0, 0, 0, 0, 1}));
  EXPECT_EQ(ct.data, kSampleHu);
}

TEST(Nrrd, RasSpaceIsConvertedToLps) {
  TempDir dir;
  const std::string header = with(kHeader, "left-posterior-superior", "RAS");
  write_header_and_data(dir.file("ras.nrrd"), header, payload(kSampleHu));
  const CtVolume ct = read_ct(dir.file("ras.nrrd"));
  EXPECT_EQ(ct.grid.world.origin, (Vec3{10.5, -20, 300.25}));
  EXPECT_EQ(ct.grid.world.direction, (std::array<double, 9>{0, 1, 0, -1, 0, 0, 0, 0, 1}));
  write_header_and_data(dir.file("las.nrrd"),
                        with(kHeader, "left-posterior-superior", "left-anterior-superior"),
                        payload(kSampleHu));
  EXPECT_EQ(read_ct(dir.file("las.nrrd")).grid.world.origin, (Vec3{-10.5, -20, 300.25}));
}

TEST(Nrrd, GzipEncodingBigEndianAndTypeSpellings) {
  TempDir dir;
  const std::string header =
      with(with(kHeader, "encoding: raw", "encoding: gzip"), "endian: little", "endian: big");
  write_header_and_data(dir.file("g.nrrd"), header,
                        gzip_compress(ByteSpan(payload(kSampleHu, true))));
  EXPECT_EQ(read_ct(dir.file("g.nrrd")).data, kSampleHu);
  for (const char* spelling :
       {"int16", "int16_t", "signed short", "short int", "signed short int"}) {
    write_header_and_data(
        dir.file("s.nrrd"),
        with(with(header, "type: short", std::string("type: ") + spelling), "gzip", "gz"),
        gzip_compress(ByteSpan(payload(kSampleHu, true))));
    EXPECT_EQ(read_ct(dir.file("s.nrrd")).data, kSampleHu) << spelling;
  }
  const std::vector<float> f{-1000.4f, 0.5f, 99.5f, 1e6f, 0, 0, 0, 0, 0, 0, 0, 0};
  write_header_and_data(dir.file("f.nrrd"), with(kHeader, "type: short", "type: float"),
                        payload(f));
  EXPECT_EQ(read_ct(dir.file("f.nrrd")).data[2], 100);
  const std::vector<std::uint16_t> u{0, 1, 40000, 3, 0, 0, 0, 0, 0, 0, 0, 0};
  for (const char* spelling :
       {"ushort", "unsigned short", "uint16", "uint16_t", "unsigned short int"}) {
    write_header_and_data(dir.file("u.nrrd"),
                          with(kHeader, "type: short", std::string("type: ") + spelling),
                          payload(u));
    EXPECT_EQ(read_ct(dir.file("u.nrrd")).data[2], 32767) << spelling;
  }
  const std::vector<std::uint8_t> b{0, 1, 255, 3, 0, 0, 0, 0, 0, 0, 0, 0};
  for (const char* spelling : {"uchar", "unsigned char", "uint8", "uint8_t"}) {
    write_header_and_data(dir.file("b.nrrd"),
                          with(kHeader, "type: short", std::string("type: ") + spelling),
                          payload(b));
    EXPECT_EQ(read_ct(dir.file("b.nrrd")).data[2], 255) << spelling;
  }
  const std::vector<std::int32_t> i{0, 1, -1024, 3, 0, 0, 0, 0, 0, 0, 0, 0};
  for (const char* spelling : {"int", "signed int", "int32", "int32_t"}) {
    write_header_and_data(dir.file("i.nrrd"),
                          with(kHeader, "type: short", std::string("type: ") + spelling),
                          payload(i));
    EXPECT_EQ(read_ct(dir.file("i.nrrd")).data[2], -1024) << spelling;
  }
  const std::vector<double> d{0, 1, -2.5, 3, 0, 0, 0, 0, 0, 0, 0, 0};
  write_header_and_data(dir.file("d.nrrd"), with(kHeader, "type: short", "type: double"),
                        payload(d));
  EXPECT_EQ(read_ct(dir.file("d.nrrd")).data[2], -3);
}

TEST(Nrrd, DetachedHeaderWithSpacingsAndSkips) {
  TempDir dir;
  auto data = std::vector<std::uint8_t>{'l', 'i',  'n', 'e', '\n',
                                        'x', '\n', 'a', 'b', 'c'};  // 2 lines + 3 bytes
  const auto values = payload(kSampleHu);
  data.insert(data.end(), values.begin(), values.end());
  write_bytes(dir.file("v.raw"), data);
  write_text(dir.file("v.nhdr"),
             "NRRD0005\n"
             "type: int16\n"
             "dimension: 3\n"
             "sizes: 3 2 2\n"
             "spacings: 0.8 0.8 -2.5\n"
             "encoding: raw\n"
             "endian: little\n"
             "line skip: 2\n"
             "byte skip: 3\n"
             "data file: v.raw\n");
  const CtVolume ct = read_ct(dir.file("v.nhdr"));
  EXPECT_EQ(ct.grid.spacing, (Vec3{0.8, 0.8, 2.5}));
  EXPECT_EQ(ct.grid.world, WorldPlacement{});
  EXPECT_EQ(ct.data, kSampleHu);

  write_text(dir.file("end.nhdr"),
             "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 2 2\nencoding: raw\nendian: little\n"
             "byte skip: -1\ndatafile: v.raw\n");
  EXPECT_EQ(read_ct(dir.file("end.nhdr")).data, kSampleHu);
}

// ---- bad input ----

TEST(NrrdErrors, UnsupportedEncodingAndType) {
  TempDir dir;
  write_header_and_data(dir.file("e.nrrd"), with(kHeader, "encoding: raw", "encoding: bzip2"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("e.nrrd")), InputError,
                    "e.nrrd: encoding bzip2 not supported");
  write_header_and_data(dir.file("a.nrrd"), with(kHeader, "encoding: raw", "encoding: ascii"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("a.nrrd")), InputError, "encoding ascii not supported");
  write_header_and_data(dir.file("t.nrrd"), with(kHeader, "type: short", "type: block"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("t.nrrd")), InputError, "type \"block\" is not supported");
  write_header_and_data(dir.file("d.nrrd"), with(kHeader, "dimension: 3", "dimension: 4"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("d.nrrd")), InputError, "dimension 4 is not supported");
  write_header_and_data(dir.file("s.nrrd"),
                        with(kHeader, "left-posterior-superior", "left-posterior-superior-time"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("s.nrrd")), InputError,
                    "space \"left-posterior-superior-time\"");
}

TEST(NrrdErrors, MalformedFields) {
  TempDir dir;
  write_header_and_data(dir.file("v.nrrd"), with(kHeader, "(0,0,2)", "(0,zero,2)"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("v.nrrd")), InputError, "space directions");
  write_header_and_data(dir.file("n.nrrd"), with(kHeader, "(0,0,2)", "none"), payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("n.nrrd")), InputError, "axis 2 is \"none\"");
  write_header_and_data(dir.file("z.nrrd"), with(kHeader, "sizes: 3 2 2", "sizes: 3 0 2"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("z.nrrd")), InputError, "dimensions 3x0x2 are not usable");
  write_header_and_data(dir.file("x.nrrd"), with(kHeader, "sizes: 3 2 2", "sizes: 3 2 two"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("x.nrrd")), InputError, "sizes \"3 2 two\" is not 3 integers");
  write_header_and_data(dir.file("m.nrrd"), "NRRD0009\ntype: short\n\n", payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("m.nrrd")), InputError, "not a NRRD file");
  write_header_and_data(dir.file("l.nrrd"),
                        with(kHeader, "kinds: domain domain domain", "kinds domain"),
                        payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("l.nrrd")), InputError, "expected \"field: value\"");
  write_header_and_data(dir.file("q.nrrd"), with(kHeader, "type: short\n", ""), payload(kSampleHu));
  EXPECT_PALP_ERROR(read_ct(dir.file("q.nrrd")), InputError, "missing field \"type\"");
  write_text(dir.file("nodata.nhdr"),
             "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 2 2\nencoding: raw\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("nodata.nhdr")), InputError, "no data");
  write_text(
      dir.file("gone.nhdr"),
      "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 2 2\nencoding: raw\ndata file: gone.raw\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("gone.nhdr")), InputError,
                    "gone.raw: no such file or directory");
}

// A detached data file must be a regular file: a symlink loop is named as one (it was reported
// missing), a FIFO is refused without waiting for a writer.
TEST(NrrdErrors, DataFileThatIsNotARegularFile) {
  TempDir dir;
  std::filesystem::create_symlink("loop.raw", dir.file("loop.raw"));
  write_text(
      dir.file("loop.nhdr"),
      "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 2 2\nencoding: raw\ndata file: loop.raw\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("loop.nhdr")), InputError,
                    "loop.nhdr: data file " + dir.file("loop.raw") + ": a loop of symbolic links");
  ASSERT_EQ(::mkfifo(dir.file("fifo.raw").c_str(), 0600), 0);
  write_text(
      dir.file("fifo.nhdr"),
      "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 2 2\nencoding: raw\ndata file: fifo.raw\n");
  EXPECT_PALP_ERROR(read_ct(dir.file("fifo.nhdr")), InputError,
                    "fifo.raw: a FIFO, not a regular file");
}

TEST(NrrdErrors, ShortAndTruncatedData) {
  TempDir dir;
  auto raw = payload(kSampleHu);
  raw.resize(7);
  write_header_and_data(dir.file("short.nrrd"), kHeader, raw);
  EXPECT_PALP_ERROR(read_ct(dir.file("short.nrrd")), InputError,
                    "short.nrrd: header says 24 bytes of voxel data, file has 7");
  auto packed = gzip_compress(ByteSpan(payload(std::vector<std::int16_t>(3000, 9))));
  packed.resize(packed.size() - 12);
  write_header_and_data(
      dir.file("cut.nrrd"),
      with(with(kHeader, "encoding: raw", "encoding: gzip"), "sizes: 3 2 2", "sizes: 30 10 10"),
      packed);
  EXPECT_PALP_ERROR(read_ct(dir.file("cut.nrrd")), InputError, "cut.nrrd: truncated gzip stream");
}

// read_nrrd_layered_header: the key:=value pairs and a leading "list" axis, as 3D Slicer writes a
// segmentation whose segments overlap (sizes: layers x y z, space directions: none (...) ...).
TEST(NrrdLayered, KeyValuesAndLeadingListAxis) {
  TempDir dir;
  const std::string header =
      "NRRD0004\n"
      "type: unsigned char\n"
      "dimension: 4\n"
      "space: left-posterior-superior\n"
      "sizes: 2 3 2 1\n"
      "space directions: none (-3,0,0) (0,-3,0) (0,0,10)\n"
      "kinds: list domain domain domain\n"
      "encoding: raw\n"
      "space origin: (193,216,-340)\n"
      "Segment0_Name:=ribs\n"
      "Segment1_Name:=two\\nlines \\\\ here\n"
      "Segment0_Name:=ribs again\n"
      "\n";
  write_header_and_data(dir.file("s.seg.nrrd"), header, std::vector<std::uint8_t>(12, 1));
  const NrrdLayeredImage image = read_nrrd_layered_header(dir.file("s.seg.nrrd"));
  EXPECT_EQ(image.components, 2);
  EXPECT_EQ(image.image.grid.dims, (Index3{3, 2, 1}));
  EXPECT_EQ(image.image.grid.spacing, (Vec3{3, 3, 10}));
  EXPECT_EQ(image.image.grid.world.direction, (std::array<double, 9>{-1, 0, 0, 0, -1, 0, 0, 0, 1}));
  EXPECT_EQ(image.image.grid.world.origin, (Vec3{193, 216, -340}));
  EXPECT_EQ(image.image.voxels.type, ScalarType::u8);
  EXPECT_EQ(image.key_values.at("Segment0_Name"), "ribs again");
  EXPECT_EQ(image.key_values.at("Segment1_Name"), "two\nlines \\ here");

  // The voxels start after the blank line; read_nrrd_header (CTs) still refuses four dimensions.
  EXPECT_EQ(read_nrrd_layered_header(dir.file("s.seg.nrrd")).image.voxels.file_offset,
            header.size());
  EXPECT_PALP_ERROR(read_nrrd_header(dir.file("s.seg.nrrd")), InputError,
                    "dimension 4 is not supported (must be 3)");
  write_header_and_data(
      dir.file("d.nrrd"),
      with(header, "kinds: list domain domain domain", "kinds: domain domain domain list"),
      std::vector<std::uint8_t>(12, 1));
  EXPECT_PALP_ERROR(read_nrrd_layered_header(dir.file("d.nrrd")), InputError,
                    "needs a non-spatial first axis");
  write_header_and_data(dir.file("n.nrrd"), with(header, "none (-3,0,0)", "(1,0,0) (-3,0,0)"),
                        std::vector<std::uint8_t>(12, 1));
  EXPECT_PALP_ERROR(read_nrrd_layered_header(dir.file("n.nrrd")), InputError,
                    "is not \"none\" and three (x,y,z) vectors");
  write_header_and_data(
      dir.file("p.nrrd"),
      with(header, "space directions: none (-3,0,0) (0,-3,0) (0,0,10)", "spacings: nan 1.5 2 2.5"),
      std::vector<std::uint8_t>(12, 1));
  EXPECT_EQ(read_nrrd_layered_header(dir.file("p.nrrd")).image.grid.spacing, (Vec3{1.5, 2, 2.5}));
}

}  // namespace
}  // namespace palp
