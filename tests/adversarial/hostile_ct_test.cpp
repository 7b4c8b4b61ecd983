// Adversarial suite, CT input: corrupt and lying NIfTI, MetaImage, NRRD and DICOM inputs (raw
// and compressed), each run through the built `palp prep`. Every one must end cleanly with exit
// code 1, one line on stderr ("palp: error: ..." naming what is wrong), within 20 s, and with a
// peak memory (ru_maxrss of the child and the GDCM child it waits for) under kPeakBound. Before
// issue 16 several of these cost gigabytes or never ended.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>

#include "adversarial/adversarial_util.hpp"
#include "io/gzip.hpp"

namespace palp::adversarial {
namespace {

namespace fs = std::filesystem;

// What any of these inputs may cost `palp prep` (its own baseline is about 20 MiB).
constexpr std::size_t kPeakBound = std::size_t{96} << 20;

const ScratchDir& scratch() {
  static const ScratchDir dir("ct");
  return dir;
}

void write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::vector<std::uint8_t> noise(std::size_t n) {
  std::vector<std::uint8_t> out(n);
  std::uint32_t state = 2463534242u;
  for (auto& b : out) {
    state ^= state << 13;
    state ^= state >> 17;
    state ^= state << 5;
    b = static_cast<std::uint8_t>(state);
  }
  return out;
}

std::vector<std::uint8_t> gzip(const std::vector<std::uint8_t>& bytes) {
  return gzip_compress(ByteSpan(bytes));
}

template <class T>
void put(std::vector<std::uint8_t>& out, std::size_t at, T value) {
  if (out.size() < at + sizeof(T)) out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &value, sizeof(T));
}

// A single-file NIfTI-1 header (352 bytes) for int16 voxels, then `data`.
std::vector<std::uint8_t> nifti(std::array<std::int16_t, 4> dim, std::vector<std::uint8_t> data,
                                float spacing = 1.0f, float vox_offset = 352.0f,
                                std::int16_t datatype = 4) {
  std::vector<std::uint8_t> out(352, 0);
  put<std::int32_t>(out, 0, 348);
  for (int a = 0; a < 4; ++a) put<std::int16_t>(out, 40 + 2 * static_cast<std::size_t>(a), dim[a]);
  for (int a = 4; a < 8; ++a) put<std::int16_t>(out, 40 + 2 * static_cast<std::size_t>(a), 1);
  put<std::int16_t>(out, 70, datatype);
  put<std::int16_t>(out, 72, 16);
  for (int a = 0; a < 4; ++a) put<float>(out, 76 + 4 * static_cast<std::size_t>(a), spacing);
  put<float>(out, 108, vox_offset);
  std::memcpy(out.data() + 344, "n+1\0", 4);
  out.resize(352 + data.size());
  if (!data.empty()) std::memcpy(out.data() + 352, data.data(), data.size());
  return out;
}

// ---- hand-built DICOM (explicit VR little endian, or RLE) ----

struct DicomWriter {
  std::vector<std::uint8_t> bytes = std::vector<std::uint8_t>(128, 0);
  DicomWriter() { bytes.insert(bytes.end(), {'D', 'I', 'C', 'M'}); }
  void element(std::uint16_t g, std::uint16_t e, const char* vr, const std::string& value) {
    std::string v = value;
    if (v.size() % 2) v += (vr[0] == 'U' && vr[1] == 'I') ? '\0' : ' ';
    append_header(g, e, vr, static_cast<std::uint32_t>(v.size()));
    bytes.insert(bytes.end(), v.begin(), v.end());
  }
  void us(std::uint16_t g, std::uint16_t e, std::uint16_t value) {
    append_header(g, e, "US", 2);
    put(bytes, bytes.size(), value);
  }
  void append_header(std::uint16_t g, std::uint16_t e, const char* vr, std::uint32_t length) {
    put(bytes, bytes.size(), g);
    put(bytes, bytes.size(), e);
    bytes.push_back(static_cast<std::uint8_t>(vr[0]));
    bytes.push_back(static_cast<std::uint8_t>(vr[1]));
    const bool long_vr = std::string("OBOWSQUNUT").find(std::string(vr, 2)) != std::string::npos;
    if (long_vr) {
      put<std::uint16_t>(bytes, bytes.size(), 0);
      put(bytes, bytes.size(), length);
    } else {
      put(bytes, bytes.size(), static_cast<std::uint16_t>(length));
    }
  }
  void item(std::uint16_t e, std::uint32_t length) {
    put<std::uint16_t>(bytes, bytes.size(), 0xfffe);
    put(bytes, bytes.size(), e);
    put(bytes, bytes.size(), length);
  }
};

// A CT slice: `columns` x `rows` int16, at z = k; RLE with a tiny fragment or native pixels of
// `native_bytes`.
std::vector<std::uint8_t> dicom_slice(std::uint16_t columns, std::uint16_t rows, int k, bool rle,
                                      std::uint32_t native_bytes = 0) {
  DicomWriter w;
  w.element(0x0002, 0x0002, "UI", "1.2.840.10008.5.1.4.1.1.2");
  w.element(0x0002, 0x0010, "UI", rle ? "1.2.840.10008.1.2.5" : "1.2.840.10008.1.2.1");
  w.element(0x0008, 0x0016, "UI", "1.2.840.10008.5.1.4.1.1.2");
  w.element(0x0008, 0x0060, "CS", "CT");
  w.element(0x0020, 0x000e, "UI", "1.2.826.0.1.3680043.2.1125.9");
  w.element(0x0020, 0x0032, "DS", "0\\0\\" + std::to_string(k));
  w.element(0x0020, 0x0037, "DS", "1\\0\\0\\0\\1\\0");
  w.us(0x0028, 0x0002, 1);
  w.element(0x0028, 0x0004, "CS", "MONOCHROME2");
  w.us(0x0028, 0x0010, rows);
  w.us(0x0028, 0x0011, columns);
  w.element(0x0028, 0x0030, "DS", "1\\1");
  w.us(0x0028, 0x0100, 16);
  w.us(0x0028, 0x0101, 16);
  w.us(0x0028, 0x0102, 15);
  w.us(0x0028, 0x0103, 1);
  if (rle) {
    w.append_header(0x7fe0, 0x0010, "OB", 0xffffffffu);
    w.item(0xe000, 0);
    std::vector<std::uint8_t> fragment(64, 0);  // RLE header: one segment at offset 64
    put<std::uint32_t>(fragment, 0, 1);
    put<std::uint32_t>(fragment, 4, 64);
    fragment.insert(fragment.end(), {0x81, 0x00, 0x81, 0x00});  // 2 x "repeat 0 128 times"
    w.item(0xe000, static_cast<std::uint32_t>(fragment.size()));
    w.bytes.insert(w.bytes.end(), fragment.begin(), fragment.end());
    w.item(0xe0dd, 0);
  } else {
    w.append_header(0x7fe0, 0x0010, "OW", native_bytes);
    w.bytes.resize(w.bytes.size() + native_bytes, 0);
  }
  return w.bytes;
}

// ---- the cases ----

struct Case {
  std::string name;
  std::function<std::string()> make;  // builds the input, returns the path prep gets
  std::string message;                // a fragment of the one-line error
};

std::vector<Case> cases() {
  const ScratchDir& d = scratch();
  const auto file = [&d](const std::string& name) { return d.file(name); };
  std::vector<Case> all;
  // NIfTI
  all.push_back({"nii-garbage",
                 [=] {
                   write_text(file("garbage.nii"), "not a header");
                   return file("garbage.nii");
                 },
                 "not a NIfTI-1 file"});
  all.push_back({"nii-huge-dims-short-data",
                 [=] {
                   write_bytes(file("huge.nii"), nifti({3, 16000, 16000, 16000}, noise(100)));
                   return file("huge.nii");
                 },
                 "header says 8192000000000 bytes of voxel data, file has 100"});
  all.push_back(
      {"nii-gz-claims-2GB-holds-3MB",
       [=] {
         write_bytes(file("liar.nii.gz"), gzip(nifti({3, 1000, 1000, 1000}, noise(3000000))));
         return file("liar.nii.gz");
       },
       "header says 2000000000 bytes of voxel data, file has 3000000"});
  all.push_back(
      {"nii-gz-beyond-deflate-ratio",
       [=] {
         write_bytes(file("ratio.nii.gz"), gzip(nifti({3, 16000, 16000, 16000}, noise(64))));
         return file("ratio.nii.gz");
       },
       "compressed bytes (at most"});
  all.push_back({"nii-gz-truncated",
                 [=] {
                   auto bytes = gzip(nifti({3, 100, 100, 50}, noise(1000000)));
                   bytes.resize(bytes.size() / 2);
                   write_bytes(file("cut.nii.gz"), bytes);
                   return file("cut.nii.gz");
                 },
                 "truncated gzip stream"});
  all.push_back({"nii-gz-corrupt",
                 [=] {
                   auto bytes = gzip(nifti({3, 100, 100, 50}, noise(1000000)));
                   for (std::size_t at = 2000; at < bytes.size(); at += 997) bytes[at] ^= 0x5a;
                   write_bytes(file("corrupt.nii.gz"), bytes);
                   return file("corrupt.nii.gz");
                 },
                 "corrupt gzip data"});
  all.push_back({"nii-vox-offset-beyond-file",
                 [=] {
                   write_bytes(file("offset.nii"), nifti({3, 4, 4, 4}, noise(128), 1.0f, 1e11f));
                   return file("offset.nii");
                 },
                 "header says 128 bytes of voxel data, file has 0"});
  all.push_back({"nii-spacing-1e-30",
                 [=] {
                   write_bytes(file("tiny.nii"), nifti({3, 4, 4, 4}, noise(128), 1e-30f));
                   return file("tiny.nii");
                 },
                 "is not usable (each must be in [0.001, 100] mm)"});
  all.push_back({"nii-negative-dims",
                 [=] {
                   write_bytes(file("neg.nii"), nifti({3, -4, 4, 4}, noise(128)));
                   return file("neg.nii");
                 },
                 "dimensions -4x4x4 are not usable"});
  all.push_back(
      {"nii-complex-datatype",
       [=] {
         write_bytes(file("complex.nii"), nifti({3, 4, 4, 4}, noise(128), 1.0f, 352.0f, 32));
         return file("complex.nii");
       },
       "NIfTI datatype 32 (complex64) is not supported"});
  all.push_back({"nii-fifo",
                 [=] {
                   ::mkfifo(file("fifo.nii").c_str(), 0600);
                   return file("fifo.nii");
                 },
                 "a FIFO, not a regular file"});
  // MetaImage
  const std::string mha = "ObjectType = Image\nNDims = 3\nElementType = MET_SHORT\n";
  all.push_back({"mha-data-file-dev-zero",
                 [=] {
                   write_text(file("zero.mhd"),
                              mha + "DimSize = 64 64 64\nElementDataFile = /dev/zero\n");
                   return file("zero.mhd");
                 },
                 "/dev/zero: a character device, not a regular file"});
  all.push_back({"mha-data-file-symlink-loop",
                 [=] {
                   fs::create_symlink("loop.raw", file("loop.raw"));
                   write_text(file("loop.mhd"),
                              mha + "DimSize = 4 4 4\nElementDataFile = loop.raw\n");
                   return file("loop.mhd");
                 },
                 "a loop of symbolic links"});
  all.push_back({"input-symlink-loop",  // the INPUT itself (reported "no such file" before)
                 [=] {
                   fs::create_symlink("self.nii", file("self.nii"));
                   return file("self.nii");
                 },
                 "self.nii: a loop of symbolic links"});
  all.push_back({"mha-data-file-missing-dotdot",
                 [=] {
                   write_text(file("gone.mhd"),
                              mha + "DimSize = 4 4 4\nElementDataFile = ../../no/such.raw\n");
                   return file("gone.mhd");
                 },
                 "no such file or directory"});
  all.push_back({"mha-zlib-claims-2GB-holds-3MB",
                 [=] {
                   std::string text =
                       mha +
                       "DimSize = 1000 1000 1000\nCompressedData = True\nElementDataFile = LOCAL\n";
                   std::vector<std::uint8_t> bytes(text.begin(), text.end());
                   const auto z = gzip(noise(3000000));
                   bytes.insert(bytes.end(), z.begin(), z.end());
                   write_bytes(file("liar.mha"), bytes);
                   return file("liar.mha");
                 },
                 "header says 2000000000 bytes of voxel data, file has 3000000"});
  all.push_back({"mha-header-without-end",
                 [=] {
                   write_text(file("endless.mha"), mha + std::string(2 << 20, 'x'));
                   return file("endless.mha");
                 },
                 "not a MetaImage header"});
  // NRRD
  const std::string nrrd = "NRRD0004\ntype: short\ndimension: 3\n";
  all.push_back({"nrrd-gzip-claims-2GB-holds-3MB",
                 [=] {
                   std::string text =
                       nrrd + "sizes: 1000 1000 1000\nencoding: gzip\nendian: little\n\n";
                   std::vector<std::uint8_t> bytes(text.begin(), text.end());
                   const auto z = gzip(noise(3000000));
                   bytes.insert(bytes.end(), z.begin(), z.end());
                   write_bytes(file("liar.nrrd"), bytes);
                   return file("liar.nrrd");
                 },
                 "header says 2000000000 bytes of voxel data, file has 3000000"});
  all.push_back({"nrrd-raw-short",
                 [=] {
                   write_text(
                       file("short.nrrd"),
                       nrrd + "sizes: 512 512 512\nencoding: raw\nendian: little\n\n0123456");
                   return file("short.nrrd");
                 },
                 "header says 268435456 bytes of voxel data, file has 7"});
  all.push_back(
      {"nrrd-detached-dev-zero",
       [=] {
         write_text(
             file("zero.nhdr"),
             nrrd + "sizes: 64 64 64\nencoding: raw\nendian: little\ndata file: /dev/zero\n");
         return file("zero.nhdr");
       },
       "not a regular file"});
  all.push_back({"nrrd-bzip2",
                 [=] {
                   write_text(file("bz.nrrd"), nrrd + "sizes: 4 4 4\nencoding: bzip2\n\n");
                   return file("bz.nrrd");
                 },
                 "encoding bzip2 not supported"});
  all.push_back(
      {"nrrd-spacing-1e300",
       [=] {
         write_text(
             file("far.nrrd"),
             nrrd +
                 "sizes: 2 2 2\nspacings: 1e300 1e-300 1e300\nencoding: raw\nendian: little\n\n" +
                 std::string(16, '\0'));
         return file("far.nrrd");
       },
       "is not usable (each must be in [0.001, 100] mm)"});
  // DICOM
  all.push_back({"dicom-sparse-1GB",
                 [=] {
                   fs::create_directories(file("sparse"));
                   std::vector<std::uint8_t> head(128, 0);
                   head.insert(head.end(), {'D', 'I', 'C', 'M'});
                   write_bytes(file("sparse/zeros.dcm"), head);
                   fs::resize_file(file("sparse/zeros.dcm"), std::uint64_t{1} << 30);
                   return file("sparse");
                 },
                 "does not follow (0000,0000) in tag order"});
  all.push_back({"dicom-8-tiny-rle-claiming-16384x16384",
                 [=] {
                   fs::create_directories(file("rle"));
                   for (int k = 0; k < 8; ++k)
                     write_bytes(file("rle/s" + std::to_string(k) + ".dcm"),
                                 dicom_slice(16384, 16384, k, true));
                   return file("rle");
                 },
                 "claim 536870912 bytes of pixels"});
  all.push_back({"dicom-native-pixels-short-of-claim",
                 [=] {
                   fs::create_directories(file("native"));
                   for (int k = 0; k < 3; ++k)
                     write_bytes(file("native/s" + std::to_string(k) + ".dcm"),
                                 dicom_slice(4096, 4096, k, false, 512));
                   return file("native");
                 },
                 "claim 33554432 bytes of pixels, but its 512 bytes"});
  all.push_back({"dicom-element-past-end",
                 [=] {
                   fs::create_directories(file("cut"));
                   auto bytes = dicom_slice(16, 16, 0, false, 512);
                   bytes.resize(bytes.size() - 100);
                   write_bytes(file("cut/s0.dcm"), bytes);
                   return file("cut");
                 },
                 "an element runs past its end"});
  all.push_back({"dicom-deep-nesting",
                 [=] {
                   fs::create_directories(file("deep"));
                   DicomWriter w;
                   w.element(0x0002, 0x0010, "UI", "1.2.840.10008.1.2.1");
                   for (int n = 0; n < 5000; ++n) {
                     w.append_header(0x0009, 0x1000, "SQ", 0xffffffffu);
                     w.item(0xe000, 0xffffffffu);
                   }
                   write_bytes(file("deep/s0.dcm"), w.bytes);
                   return file("deep");
                 },
                 "sequences nested more than 32 deep"});
  return all;
}

void PrintTo(const Case& c, std::ostream* out) {
  *out << c.name;
}

class HostileCt : public ::testing::TestWithParam<Case> {};

TEST_P(HostileCt, EndsCleanlyWithOneLineAndBoundedMemory) {
  const Case& c = GetParam();
  const std::string input = c.make();
  const std::string out = scratch().file("out-" + c.name);
  Child prep({PALP_CLI_PATH, "prep", input, "--out", out, "-q"}, out + ".stdout", out + ".stderr");
  ASSERT_TRUE(prep.wait(20.0)) << c.name << ": still running after 20 s";
  const std::string err = read_text(out + ".stderr");
  EXPECT_EQ(prep.signal_number(), 0) << c.name;
  EXPECT_EQ(prep.exit_code(), 1) << c.name << ": " << err;
  EXPECT_EQ(count_lines(err), 1) << c.name << ": " << err;
  EXPECT_EQ(err.rfind("palp: error: ", 0), 0u) << c.name << ": " << err;
  EXPECT_NE(err.find(c.message), std::string::npos) << c.name << ": " << err;
  EXPECT_LT(prep.peak_bytes(), kPeakBound) << c.name;
  std::printf("%-40s exit %d  %5.2f s  peak %6.1f MiB\n", c.name.c_str(), prep.exit_code(),
              prep.seconds(), static_cast<double>(prep.peak_bytes()) / 1048576.0);
}

INSTANTIATE_TEST_SUITE_P(Inputs, HostileCt, ::testing::ValuesIn(cases()),
                         [](const ::testing::TestParamInfo<Case>& param_info) {
                           std::string name;
                           for (char ch : param_info.param.name)
                             name += std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
                           return name;
                         });

// --band beyond what `palp prep --help` promises ("at most 1e6") is refused before any work,
// as a usage mistake naming the option (1e308 ran to exit 0 before, issue 37).
TEST(HostileCtOptions, BandBeyondItsHelpIsRefused) {
  Child help({PALP_CLI_PATH, "prep", "--help"}, scratch().file("help.out"),
             scratch().file("help.err"));
  ASSERT_TRUE(help.wait(20.0));
  ASSERT_NE(read_text(scratch().file("help.out")).find("at most 1e6"), std::string::npos);
  // a scene prep completes in under a second: with --band 1e308 it did, exit 0, before
  const std::string input = "phantom:sphere";
  for (const char* band : {"1e308", "1e7", "1000000.5", "0", "nan", "inf"}) {
    const std::string out = scratch().file(std::string("out-band-") + band);
    Child prep({PALP_CLI_PATH, "prep", input, "--out", out, "--band", band, "-q"}, out + ".stdout",
               out + ".stderr");
    ASSERT_TRUE(prep.wait(20.0)) << band;
    const std::string err = read_text(out + ".stderr");
    EXPECT_EQ(prep.exit_code(), 2) << band << ": " << err;
    EXPECT_NE(err.find("--band"), std::string::npos) << band << ": " << err;
    EXPECT_FALSE(fs::exists(out)) << band << ": prep made its output directory";
  }
}

TEST(HostileCtSuite, HasAtLeastTwentyKinds) {
  EXPECT_GE(cases().size(), 20u);
}

}  // namespace
}  // namespace palp::adversarial
