// Tests for gzip.hpp: streaming inflate (multi-member, truncated, corrupt, limits), zlib
// streams, and the parallel multi-member gzip writer checked against zlib itself.
#include "io/gzip.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <numeric>
#include <optional>

#include "base/errors.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

using testing::compressible_bytes;
using testing::read_bytes;
using testing::TempDir;
using testing::write_bytes;

// One gzip member made by zlib (not by the code under test).
std::vector<std::uint8_t> zlib_gzip_member(const std::vector<std::uint8_t>& data) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, 6, Z_DEFLATED, 16 + 15, 8, Z_DEFAULT_STRATEGY), Z_OK);
  std::vector<std::uint8_t> out(deflateBound(&zs, data.size()) + 64);
  zs.next_in = const_cast<Bytef*>(data.data());
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

// Decompresses a whole (multi-member) gzip file with zlib's gz* API.
std::vector<std::uint8_t> zlib_gunzip_file(const std::string& path) {
  gzFile file = gzopen(path.c_str(), "rb");
  EXPECT_NE(file, nullptr);
  std::vector<std::uint8_t> out;
  std::uint8_t buffer[1 << 16];
  int n = 0;
  while ((n = gzread(file, buffer, sizeof buffer)) > 0) out.insert(out.end(), buffer, buffer + n);
  EXPECT_EQ(n, 0);
  gzclose(file);
  return out;
}

TEST(Gzip, ParallelMultiMemberOutputIsReadByZlibAndByTheReader) {
  TempDir dir;
  const auto data = compressible_bytes(10'000'000);
  const std::string path = dir.file("data.gz");
  GzipOptions options;
  options.member_bytes = 1 << 20;
  options.threads = 2;
  const ByteSpan piece(data);
  write_file(path, std::span<const ByteSpan>(&piece, 1), true, options);

  EXPECT_EQ(zlib_gunzip_file(path), data);
  EXPECT_TRUE(file_is_gzip(path));
  EXPECT_EQ(read_file(path, data.size()), data);
  // No temporary file is left behind.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
}

TEST(Gzip, EveryLevelAndIncompressibleDataRoundTripThroughZlib) {
  // Random bytes cannot shrink: the member must still fit (stored blocks) and decode.
  std::vector<std::uint8_t> noise(3'000'000);
  std::uint64_t state = 88172645463325252ull;
  for (auto& b : noise) {
    state ^= state << 13, state ^= state >> 7, state ^= state << 17;
    b = static_cast<std::uint8_t>(state);
  }
  std::vector<std::uint8_t> text = compressible_bytes(2'000'000);
  TempDir dir;
  for (int level = 0; level <= 3; ++level) {
    for (const std::vector<std::uint8_t>* data : {&noise, &text}) {
      GzipOptions options;
      options.level = level;
      options.member_bytes = 1'000'000;
      const ByteSpan piece(*data);
      const std::string path = dir.file("level.gz");  // rewritten each time
      write_file(path, std::span<const ByteSpan>(&piece, 1), true, options);
      EXPECT_EQ(zlib_gunzip_file(path), *data) << "level " << level;
      if (data == &text) {
        EXPECT_LT(std::filesystem::file_size(path), data->size() / 2) << "level " << level;
      }
    }
  }
}

#if defined(__x86_64__)
// XINUSE (XGETBV with ECX = 1): which register states are not in their initial configuration;
// bit 2: the upper halves of YMM0-15, bit 6: the upper halves of ZMM0-15. nullopt when the CPU
// cannot say.
std::optional<std::uint64_t> vector_state_in_use() {
  unsigned eax = 0, ebx = 0, ecx = 0, edx = 0;
  __asm__("cpuid" : "=a"(eax), "=b"(ebx), "=c"(ecx), "=d"(edx) : "a"(1), "c"(0));
  if (!(ecx & (1u << 27))) return std::nullopt;  // no OSXSAVE
  __asm__("cpuid" : "=a"(eax), "=b"(ebx), "=c"(ecx), "=d"(edx) : "a"(0xd), "c"(1));
  if (!(eax & (1u << 2))) return std::nullopt;  // no XGETBV with ECX = 1
  unsigned lo = 0, hi = 0;
  __asm__ volatile("xgetbv" : "=a"(lo), "=d"(hi) : "c"(1));
  return (std::uint64_t{hi} << 32) | lo;
}

TEST(Gzip, CompressingLeavesNoUpperVectorStateOnTheCallingThread) {
  // ISA-L's kernels return with the YMM/ZMM upper halves dirty; the SSE code the thread runs
  // next (a distance map) then ran several times slower. The writer must clear them.
  if (!vector_state_in_use()) GTEST_SKIP() << "this CPU does not report XINUSE";
  const auto data = compressible_bytes(3'000'000);
  GzipOptions options;
  options.threads = 1;  // every member on this thread
  options.member_bytes = 1 << 20;
  const auto packed = gzip_compress(ByteSpan(data), options);
  const std::uint64_t in_use = *vector_state_in_use();
  EXPECT_EQ(in_use & ((1u << 2) | (1u << 6)), 0u) << "XINUSE " << in_use;
  EXPECT_EQ(decompress(packed, Compression::gzip, data.size(), "mem"), data);
}
#endif

TEST(Gzip, BytesDoNotDependOnWhichThreadCompressedWhichMember) {
  // One thread compresses every member after the previous one; four take them as they come.
  // Float data like the maps (smooth values, repeated runs), where stale hash entries would
  // find other matches.
  std::vector<float> values(3'000'000);
  for (std::size_t i = 0; i < values.size(); ++i)
    values[i] = (i / 5000) % 3 == 0 ? -60.0f : std::round(std::sin(i * 1e-3) * 30720.0f) / 1024.0f;
  const ByteSpan bytes(reinterpret_cast<const std::uint8_t*>(values.data()),
                       values.size() * sizeof(float));
  GzipOptions one;
  one.threads = 1;
  one.member_bytes = 256 << 10;
  GzipOptions four = one;
  four.threads = 4;
  const auto reference = gzip_compress(bytes, one);
  for (int run = 0; run < 4; ++run) EXPECT_EQ(gzip_compress(bytes, four), reference) << run;
}

TEST(Gzip, PiecesStartNewMembersAndConcatenate) {
  const auto a = compressible_bytes(1000);
  const auto b = compressible_bytes(3000);
  const ByteSpan pieces[2] = {ByteSpan(a), ByteSpan(b)};
  const auto packed = gzip_compress(pieces);
  auto expected = a;
  expected.insert(expected.end(), b.begin(), b.end());
  EXPECT_EQ(decompress(packed, Compression::gzip, expected.size(), "mem"), expected);
}

TEST(Gzip, EmptyInputIsAValidGzipStream) {
  const std::vector<std::uint8_t> empty;
  const auto packed = gzip_compress(ByteSpan(empty));
  EXPECT_GE(packed.size(), 18u);
  EXPECT_TRUE(decompress(packed, Compression::gzip, 10, "mem").empty());
}

TEST(Gzip, ReadsMultiMemberFilesWrittenByZlib) {
  TempDir dir;
  const auto a = compressible_bytes(200'000);
  const auto b = compressible_bytes(50'000);
  auto file = zlib_gzip_member(a);
  const auto second = zlib_gzip_member(b);
  file.insert(file.end(), second.begin(), second.end());
  write_bytes(dir.file("two.gz"), file);
  auto expected = a;
  expected.insert(expected.end(), b.begin(), b.end());
  EXPECT_EQ(read_file(dir.file("two.gz"), 1 << 20), expected);
}

TEST(Gzip, TrailingZeroPaddingIsIgnored) {
  TempDir dir;
  const auto a = compressible_bytes(5000);
  auto file = zlib_gzip_member(a);
  file.insert(file.end(), 100, 0);
  write_bytes(dir.file("padded.gz"), file);
  EXPECT_EQ(read_file(dir.file("padded.gz"), 1 << 20), a);
}

TEST(Gzip, StreamingReaderDeliversExactChunksAndSkips) {
  TempDir dir;
  const auto data = compressible_bytes(3'000'000);
  write_bytes(dir.file("d.gz"), zlib_gzip_member(data));
  DecodedReader reader(dir.file("d.gz"), 0, Compression::gzip);
  EXPECT_EQ(reader.skip(1000), 1000u);
  std::vector<std::uint8_t> part(777);
  ASSERT_EQ(reader.read(part.data(), part.size()), part.size());
  EXPECT_TRUE(std::equal(part.begin(), part.end(), data.begin() + 1000));
  EXPECT_EQ(reader.position(), 1777u);
  std::vector<std::uint8_t> rest(data.size());
  EXPECT_EQ(reader.read(rest.data(), rest.size()), data.size() - 1777);
}

TEST(Gzip, RawReaderFromOffset) {
  TempDir dir;
  const auto data = compressible_bytes(5000);
  write_bytes(dir.file("raw.bin"), data);
  DecodedReader reader(dir.file("raw.bin"), 100, Compression::none);
  EXPECT_EQ(reader.skip(50), 50u);
  std::vector<std::uint8_t> out(10000);
  ASSERT_EQ(reader.read(out.data(), out.size()), 4850u);
  EXPECT_TRUE(std::equal(data.begin() + 150, data.end(), out.begin()));
  EXPECT_FALSE(file_is_gzip(dir.file("raw.bin")));
  EXPECT_EQ(read_file(dir.file("raw.bin"), 5000), data);
}

TEST(Gzip, TruncatedStreamIsAClearInputError) {
  TempDir dir;
  auto file = zlib_gzip_member(compressible_bytes(400'000));
  file.resize(file.size() / 2);
  write_bytes(dir.file("cut.gz"), file);
  EXPECT_PALP_ERROR(read_file(dir.file("cut.gz"), 1 << 20), InputError,
                    "cut.gz: truncated gzip stream (file ends before the compressed data does)");
}

TEST(Gzip, CorruptDataReportsZlibsMessage) {
  TempDir dir;
  auto file = zlib_gzip_member(compressible_bytes(400'000));
  for (std::size_t i = 40; i < 60; ++i) file[i] ^= 0x5a;
  write_bytes(dir.file("bad.gz"), file);
  EXPECT_PALP_ERROR(read_file(dir.file("bad.gz"), 1 << 20), InputError,
                    "bad.gz: corrupt gzip data (zlib: ");
}

TEST(Gzip, CorruptChecksumIsDetected) {
  TempDir dir;
  auto file = zlib_gzip_member(compressible_bytes(10'000));
  file[file.size() - 6] ^= 0xff;  // inside the CRC-32 of the trailer
  write_bytes(dir.file("crc.gz"), file);
  EXPECT_PALP_ERROR(read_file(dir.file("crc.gz"), 1 << 20), InputError, "incorrect data check");
}

TEST(Gzip, DecompressionBombIsRefusedAtTheLimit) {
  TempDir dir;
  const std::vector<std::uint8_t> zeros(50'000'000, 0);
  write_bytes(dir.file("bomb.gz"), zlib_gzip_member(zeros));
  EXPECT_LT(std::filesystem::file_size(dir.file("bomb.gz")), 100'000u);
  EXPECT_PALP_ERROR(read_file(dir.file("bomb.gz"), 1'000'000), InputError,
                    "decompressed content exceeds the limit of 1000000 bytes");
}

TEST(Gzip, ZlibStreamsAsInMetaImageCompressedData) {
  const auto data = compressible_bytes(123'456);
  uLongf size = compressBound(data.size());
  std::vector<std::uint8_t> packed(size);
  ASSERT_EQ(compress2(packed.data(), &size, data.data(), data.size(), 6), Z_OK);
  packed.resize(size);
  EXPECT_EQ(decompress(packed, Compression::zlib, data.size(), "mem"), data);
  packed.resize(packed.size() - 10);
  EXPECT_PALP_ERROR(decompress(packed, Compression::zlib, data.size(), "img.zraw"), InputError,
                    "img.zraw: truncated zlib stream");
}

// Reads a stream through DecodedReader in uneven chunks (crossing every member boundary).
std::vector<std::uint8_t> read_unevenly(DecodedReader& reader) {
  std::vector<std::uint8_t> out;
  std::vector<std::uint8_t> chunk(3'000'017);
  for (std::size_t want = 777;; want = want * 3 % chunk.size() + 1) {
    const std::size_t got = reader.read(chunk.data(), want);
    out.insert(out.end(), chunk.begin(), chunk.begin() + static_cast<std::ptrdiff_t>(got));
    if (got < want) return out;
  }
}

TEST(Gzip, LibdeflateAndZlibMembersMixInOneStream) {
  // Three small members (libdeflate decodes them whole), one whose output exceeds the fast
  // path's 8 MiB buffer (zlib takes over), then a small one (zlib from then on).
  const auto a = compressible_bytes(2'500'000);
  const auto big = compressible_bytes(9'000'000);
  const auto tail = compressible_bytes(1000);
  GzipOptions options;
  options.member_bytes = 1 << 20;
  auto file = gzip_compress(ByteSpan(a), options);
  const auto big_member = zlib_gzip_member(big);
  const auto tail_member = gzip_compress(ByteSpan(tail), options);
  file.insert(file.end(), big_member.begin(), big_member.end());
  file.insert(file.end(), tail_member.begin(), tail_member.end());
  auto expected = a;
  expected.insert(expected.end(), big.begin(), big.end());
  expected.insert(expected.end(), tail.begin(), tail.end());

  DecodedReader from_memory(file, Compression::gzip, "mem");
  EXPECT_EQ(read_unevenly(from_memory), expected);
  TempDir dir;
  write_bytes(dir.file("mixed.gz"), file);
  DecodedReader from_file(dir.file("mixed.gz"), 0, Compression::gzip);
  EXPECT_EQ(read_unevenly(from_file), expected);
  EXPECT_EQ(from_file.position(), expected.size());
}

TEST(Gzip, DamageInALaterMemberIsStillReported) {
  // Four members of 1 MiB written by palp; the third one's CRC, then its data, damaged, then
  // the file cut inside it: the fast path declines and zlib reports what is wrong.
  const auto data = compressible_bytes(4 << 20);
  GzipOptions options;
  options.member_bytes = 1 << 20;
  std::vector<std::uint8_t> file;
  std::size_t third_begin = 0, third_end = 0;
  for (int m = 0; m < 4; ++m) {
    const auto member =
        gzip_compress(ByteSpan(data).subspan(std::size_t(m) << 20, 1 << 20), options);
    if (m == 2) third_begin = file.size(), third_end = file.size() + member.size();
    file.insert(file.end(), member.begin(), member.end());
  }
  ASSERT_EQ(decompress(file, Compression::gzip, data.size(), "mem"), data);
  TempDir dir;
  auto crc = file;
  crc[third_end - 6] ^= 0xff;
  write_bytes(dir.file("crc.gz"), crc);
  EXPECT_PALP_ERROR(read_file(dir.file("crc.gz"), data.size()), InputError,
                    "crc.gz: corrupt gzip data (zlib: incorrect data check)");
  auto bad = file;
  for (std::size_t i = third_begin + 40; i < third_begin + 60; ++i) bad[i] ^= 0x5a;
  write_bytes(dir.file("bad.gz"), bad);
  EXPECT_PALP_ERROR(read_file(dir.file("bad.gz"), data.size()), InputError,
                    "bad.gz: corrupt gzip data (zlib: ");
  auto cut = file;
  cut.resize((third_begin + third_end) / 2);
  write_bytes(dir.file("cut.gz"), cut);
  EXPECT_PALP_ERROR(read_file(dir.file("cut.gz"), data.size()), InputError,
                    "cut.gz: truncated gzip stream");
}

TEST(Gzip, MissingFileIsNamed) {
  EXPECT_PALP_ERROR(read_file("/nonexistent/x.gz", 100), InputError,
                    "/nonexistent/x.gz: no such file or directory");
}

TEST(Gzip, UnwritableDestinationIsAResourceError) {
  const std::vector<std::uint8_t> data(10, 1);
  const ByteSpan piece(data);
  EXPECT_PALP_ERROR(
      write_file("/nonexistent/dir/out.gz", std::span<const ByteSpan>(&piece, 1), true),
      ResourceError, "cannot write /nonexistent/dir/out.gz");
}

}  // namespace
}  // namespace palp
