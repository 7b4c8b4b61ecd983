// Indexed gzip members (see gzip_index.hpp).
#include "io/gzip_index.hpp"

#include <fcntl.h>
#include <libdeflate.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <memory>
#include <vector>

#include "base/parallel.hpp"

namespace palp {
namespace {

constexpr std::uint8_t kFlagExtra = 0x04;
constexpr std::size_t kTrailerBytes = 8;
constexpr std::uint64_t kMaxRatio = 1032;  // deflate's largest expansion
constexpr std::uint32_t kMaxMemberOutput = std::uint32_t{64} << 20;

std::uint32_t le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}

bool pread_fully(int fd, void* dst, std::size_t n, std::uint64_t offset) {
  auto* out = static_cast<std::uint8_t*>(dst);
  std::size_t done = 0;
  while (done < n) {
    const ssize_t got = ::pread(fd, out + done, n - done, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return false;
    done += static_cast<std::size_t>(got);
  }
  return true;
}

struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

struct Member {
  std::uint64_t at = 0;      // file offset of its header
  std::uint32_t bytes = 0;   // its whole length in the file
  std::uint64_t out_at = 0;  // decoded offset of its first byte
  std::uint32_t out_bytes = 0;
};

// The members of the file when every one, up to the file's exact end, carries the "PZ" length.
bool index_members(int fd, std::uint64_t size, std::vector<Member>& members) {
  std::uint64_t at = 0, out_at = 0;
  while (at < size) {
    if (size - at < kIndexedHeaderBytes + kTrailerBytes) return false;
    std::uint8_t h[kIndexedHeaderBytes];
    if (!pread_fully(fd, h, sizeof h, at)) return false;
    if (h[0] != 0x1f || h[1] != 0x8b || h[2] != 8 || h[3] != kFlagExtra || h[10] != 8 ||
        h[11] != 0 || h[12] != 'P' || h[13] != 'Z' || h[14] != 4 || h[15] != 0)
      return false;
    const std::uint32_t bytes = le32(h + 16);
    if (bytes < kIndexedHeaderBytes + kTrailerBytes || bytes > size - at) return false;
    std::uint8_t trailer[4];
    if (!pread_fully(fd, trailer, sizeof trailer, at + bytes - 4)) return false;
    const std::uint32_t out_bytes = le32(trailer);
    if (out_bytes > kMaxMemberOutput || out_bytes > std::uint64_t{bytes} * kMaxRatio) return false;
    members.push_back({at, bytes, out_at, out_bytes});
    at += bytes;
    out_at += out_bytes;
  }
  return !members.empty();
}

}  // namespace

void write_indexed_header(std::uint8_t* out, std::uint32_t member_bytes) {
  const std::uint8_t header[kIndexedHeaderBytes] = {0x1f,
                                                    0x8b,
                                                    8,
                                                    kFlagExtra,  // magic, deflate, FLG.FEXTRA
                                                    0,
                                                    0,
                                                    0,
                                                    0,  // MTIME: none
                                                    0,
                                                    255,  // XFL, OS: unknown
                                                    8,
                                                    0,  // XLEN: one subfield of 4 bytes
                                                    'P',
                                                    'Z',
                                                    4,
                                                    0,  // subfield id and length
                                                    static_cast<std::uint8_t>(member_bytes),
                                                    static_cast<std::uint8_t>(member_bytes >> 8),
                                                    static_cast<std::uint8_t>(member_bytes >> 16),
                                                    static_cast<std::uint8_t>(member_bytes >> 24)};
  std::copy(header, header + kIndexedHeaderBytes, out);
}

bool read_indexed_gzip(
    const std::string& path, std::uint64_t first, std::uint64_t count, std::size_t granule,
    unsigned threads, const std::function<void()>& prepare,
    const std::function<void(std::uint64_t, const std::uint8_t*, std::size_t)>& deliver) {
  granule = std::max<std::size_t>(granule, 1);
  Fd file;
  file.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (file.fd < 0) return false;
  struct stat info {};
  if (::fstat(file.fd, &info) != 0 || !S_ISREG(info.st_mode)) return false;
  std::vector<Member> all;
  if (!index_members(file.fd, static_cast<std::uint64_t>(info.st_size), all)) return false;
  const std::uint64_t end = first + count;
  if (all.back().out_at + all.back().out_bytes < end) return false;
  std::vector<Member> needed;
  for (const Member& m : all) {
    const std::uint64_t lo = std::max(m.out_at, first), hi = std::min(m.out_at + m.out_bytes, end);
    if (lo >= hi) continue;
    if ((lo - first) % granule != 0 || (hi != end && (hi - first) % granule != 0)) return false;
    needed.push_back(m);
  }
  if (needed.empty()) return count == 0;
  prepare();
  std::atomic<bool> damaged{false};
  parallel_for_chunks(
      static_cast<std::int64_t>(needed.size()), 1,
      [&](std::int64_t b, std::int64_t e) {
        std::unique_ptr<libdeflate_decompressor, void (*)(libdeflate_decompressor*)> decoder(
            libdeflate_alloc_decompressor(), libdeflate_free_decompressor);
        std::vector<std::uint8_t> in, out;
        for (std::int64_t i = b; i < e && !damaged.load(std::memory_order_relaxed); ++i) {
          const Member& m = needed[static_cast<std::size_t>(i)];
          in.resize(m.bytes);
          out.resize(m.out_bytes);
          std::size_t produced = 0;
          if (decoder == nullptr || !pread_fully(file.fd, in.data(), in.size(), m.at) ||
              libdeflate_gzip_decompress(decoder.get(), in.data(), in.size(), out.data(),
                                         out.size(), &produced) != LIBDEFLATE_SUCCESS ||
              produced != m.out_bytes) {
            damaged = true;
            return;
          }
          const std::uint64_t lo = std::max(m.out_at, first);
          const std::uint64_t hi = std::min(m.out_at + m.out_bytes, end);
          deliver(lo - first, out.data() + (lo - m.out_at), static_cast<std::size_t>(hi - lo));
        }
      },
      std::max(threads, 1u));
  return !damaged;
}

}  // namespace palp
