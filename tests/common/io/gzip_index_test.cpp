// Tests for gzip_index.hpp: palp's members carry their length, so they are found from the
// headers and decoded in parallel, byte for byte what zlib decodes; anything else is left to the
// streaming reader without a byte delivered.
#include "io/gzip_index.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <mutex>

#include "io/ct_io.hpp"
#include "io/gzip.hpp"
#include "support/io_test_util.hpp"

namespace palp {
namespace {

using testing::compressible_bytes;
using testing::read_bytes;
using testing::TempDir;
using testing::write_bytes;

// Writes `pieces` as palp does: members of `member_bytes`, each piece starting a new one.
void write_members(const std::string& path, const std::vector<std::vector<std::uint8_t>>& pieces,
                   std::size_t member_bytes) {
  std::vector<ByteSpan> spans(pieces.begin(), pieces.end());
  GzipOptions options;
  options.member_bytes = member_bytes;
  options.threads = 2;
  write_file(path, spans, true, options);
}

struct Delivered {
  std::vector<std::uint8_t> bytes;
  std::vector<std::pair<std::uint64_t, std::size_t>> pieces;
  bool prepared = false;
};

bool read_into(const std::string& path, std::uint64_t first, std::uint64_t count,
               std::size_t granule, unsigned threads, Delivered& out) {
  out = {};
  out.bytes.assign(count, 0xAB);
  std::mutex mutex;
  return read_indexed_gzip(
      path, first, count, granule, threads, [&] { out.prepared = true; },
      [&](std::uint64_t at, const std::uint8_t* bytes, std::size_t size) {
        EXPECT_TRUE(out.prepared);
        EXPECT_LE(at + size, count);
        std::memcpy(out.bytes.data() + at, bytes, size);
        const std::lock_guard<std::mutex> lock(mutex);
        out.pieces.emplace_back(at, size);
      });
}

TEST(GzipIndex, EveryMemberCarriesItsLengthAndZlibStillReadsTheFile) {
  TempDir dir;
  const auto header = compressible_bytes(352), data = compressible_bytes(5'000'000);
  const std::string path = dir.file("v.gz");
  write_members(path, {header, data}, 1 << 20);
  const auto file = read_bytes(path);
  // The first member (the 352-byte piece) starts with the indexed header; its length field
  // points at the second member's magic.
  ASSERT_GE(file.size(), kIndexedHeaderBytes);
  EXPECT_EQ(file[3], 0x04);  // FLG.FEXTRA
  EXPECT_EQ(file[12], 'P');
  EXPECT_EQ(file[13], 'Z');
  const std::uint32_t first_member =
      file[16] | (file[17] << 8) | (file[18] << 16) | (static_cast<std::uint32_t>(file[19]) << 24);
  ASSERT_LT(first_member + 1, file.size());
  EXPECT_EQ(file[first_member], 0x1f);
  EXPECT_EQ(file[first_member + 1], 0x8b);
  // zlib (and so gzip, ITK, nibabel) reads the extra field past.
  std::vector<std::uint8_t> all(header);
  all.insert(all.end(), data.begin(), data.end());
  EXPECT_EQ(read_file(path, all.size()), all);
}

TEST(GzipIndex, DecodesAnyRangeOnGranulesForAnyThreadCount) {
  TempDir dir;
  const auto header = compressible_bytes(352), data = compressible_bytes(3'000'000);
  const std::string path = dir.file("v.gz");
  write_members(path, {header, data}, 1 << 18);  // 12 data members
  for (const unsigned threads : {1u, 2u, 5u}) {
    Delivered got;
    ASSERT_TRUE(read_into(path, 352, data.size(), 4, threads, got)) << threads;
    EXPECT_EQ(got.bytes, data) << threads;
    EXPECT_EQ(got.pieces.size(), 12u);
    // A range ending inside a member: the last piece is cut there.
    ASSERT_TRUE(read_into(path, 352 + (1 << 18), 1'000'001, 4, threads, got));
    EXPECT_EQ(got.bytes, std::vector<std::uint8_t>(data.begin() + (1 << 18),
                                                   data.begin() + (1 << 18) + 1'000'001));
  }
}

TEST(GzipIndex, LeavesEverythingElseToTheStreamingReaderWithoutDelivering) {
  TempDir dir;
  const auto header = compressible_bytes(352), data = compressible_bytes(1'000'000);
  const std::string path = dir.file("v.gz");
  write_members(path, {header, data}, 1 << 18);
  Delivered got;
  // Members that do not fall on the granule, or a file shorter than the range.
  EXPECT_FALSE(read_into(path, 352, data.size(), 3, 2, got));
  EXPECT_FALSE(got.prepared);
  EXPECT_FALSE(read_into(path, 352, data.size() + 1, 4, 2, got));
  EXPECT_FALSE(got.prepared);
  // A foreign gzip file (one zlib member, no length field).
  const std::string foreign = dir.file("foreign.gz");
  {
    gzFile out = gzopen(foreign.c_str(), "wb");
    ASSERT_NE(out, nullptr);
    gzwrite(out, data.data(), static_cast<unsigned>(data.size()));
    gzclose(out);
  }
  EXPECT_FALSE(read_into(foreign, 0, data.size(), 1, 2, got));
  EXPECT_FALSE(got.prepared);
  // Trailing bytes after the last member, and a length field pointing past the file.
  auto bytes = read_bytes(path);
  bytes.push_back(0);
  write_bytes(dir.file("trailing.gz"), bytes);
  EXPECT_FALSE(read_into(dir.file("trailing.gz"), 352, data.size(), 4, 2, got));
  bytes.pop_back();
  bytes[16] = 0xff, bytes[17] = 0xff, bytes[18] = 0xff;
  write_bytes(dir.file("long.gz"), bytes);
  EXPECT_FALSE(read_into(dir.file("long.gz"), 352, data.size(), 4, 2, got));
  EXPECT_FALSE(got.prepared);
  EXPECT_FALSE(read_into(dir.file("missing.gz"), 0, 1, 1, 2, got));
}

TEST(GzipIndex, DamagedMemberIsReportedAsNotRead) {
  TempDir dir;
  const auto data = compressible_bytes(1'000'000);
  const std::string path = dir.file("v.gz");
  write_members(path, {data}, 1 << 18);
  auto bytes = read_bytes(path);
  bytes[bytes.size() - 6] ^= 0x5a;  // the last member's CRC
  write_bytes(path, bytes);
  Delivered got;
  EXPECT_FALSE(read_into(path, 0, data.size(), 1, 2, got));
}

// read_ct takes the parallel path for palp's files and the streaming one for others: both give
// the same volume.
TEST(GzipIndex, ReadCtGivesTheSameVolumeByEitherPath) {
  TempDir dir;
  Grid grid;
  grid.dims = {64, 48, 40};
  grid.spacing = {0.8, 0.8, 1.5};
  CtVolume ct(grid, 0, "ct");
  for (std::size_t i = 0; i < ct.data.size(); ++i)
    ct.data[i] = static_cast<std::int16_t>(static_cast<int>(i * 7919 % 3000) - 1000);
  const std::string palp_file = dir.file("palp.nii.gz");
  write_nifti(palp_file, ct);
  // The same decoded bytes as one zlib member.
  const std::string foreign = dir.file("foreign.nii.gz");
  const auto decoded = read_file(palp_file, std::size_t{1} << 30);
  {
    gzFile out = gzopen(foreign.c_str(), "wb");
    ASSERT_NE(out, nullptr);
    gzwrite(out, decoded.data(), static_cast<unsigned>(decoded.size()));
    gzclose(out);
  }
  Delivered got;
  ASSERT_TRUE(read_into(palp_file, 352, ct.data.size() * 2, 2, 2, got));
  ASSERT_FALSE(read_into(foreign, 352, ct.data.size() * 2, 2, 2, got));
  EXPECT_EQ(read_ct(palp_file).data, ct.data);
  EXPECT_EQ(read_ct(foreign).data, ct.data);
}

}  // namespace
}  // namespace palp
