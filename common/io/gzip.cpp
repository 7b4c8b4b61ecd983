// Streaming inflate for reading (raw, gzip with multiple members, zlib) and parallel gzip
// compression (ISA-L igzip) for writing. See gzip.hpp.
#include "io/gzip.hpp"

#include <fcntl.h>
#include <isa-l/igzip_lib.h>
#include <libdeflate.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <limits>

#include "base/errors.hpp"
#include "io/gzip_index.hpp"

namespace palp {
namespace {

constexpr std::size_t kInputBufferBytes = std::size_t{1} << 20;
constexpr std::size_t kMaxZlibChunk = std::size_t{1} << 30;  // fits zlib's uInt
// The libdeflate fast path decodes a whole gzip member at once: the compressed member must fit
// this window and its output this buffer (palp writes members of 4 MiB input; others fall back).
constexpr std::size_t kFastWindowBytes = std::size_t{8} << 20;
constexpr std::size_t kFastMemberBytes = std::size_t{8} << 20;
// Larger members are written without their length (they never are: members hold 4 MiB).
constexpr std::size_t kMaxIndexedMemberInput = std::size_t{64} << 20;

std::string errno_text(int error) {
  return std::strerror(error);
}

[[noreturn]] void throw_open_error(const std::string& path, int error) {
  if (error == ENOENT) throw InputError(path + ": no such file or directory");
  if (error == ELOOP) throw InputError(path + ": a loop of symbolic links");
  throw InputError(path + ": cannot open (" + errno_text(error) + ")");
}

const char* kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// Opens without blocking (a FIFO would wait for a writer forever), refuses anything that is not
// a regular file, then reads blocking as usual.
int open_for_reading(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd < 0) throw_open_error(path, errno);
  struct stat info {};
  if (::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
    const mode_t mode = info.st_mode;
    ::close(fd);
    throw InputError(path + ": " + kind_of(mode) + ", not a regular file: palp reads files only");
  }
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  return fd;
}

// Reads up to n bytes from fd, retrying short reads; returns fewer only at end of file.
std::size_t read_fully(int fd, std::uint8_t* dst, std::size_t n, const std::string& what) {
  std::size_t done = 0;
  while (done < n) {
    const ssize_t got = ::read(fd, dst + done, std::min(n - done, kMaxZlibChunk));
    if (got < 0) {
      if (errno == EINTR) continue;
      throw InputError(what + ": read error (" + errno_text(errno) + ")");
    }
    if (got == 0) break;
    done += static_cast<std::size_t>(got);
  }
  return done;
}

const char* stream_name(Compression compression) {
  return compression == Compression::gzip ? "gzip" : "zlib";
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// DecodedReader

struct DecodedReader::Impl {
  std::string what;
  Compression compression = Compression::none;
  // Source: a file descriptor, or memory when fd < 0.
  int fd = -1;
  std::uint64_t file_bytes = 0;  // size of the file (file source)
  std::uint64_t raw_offset = 0;  // where raw reading continues (file source, no compression)
  ByteSpan memory;
  std::size_t memory_pos = 0;  // memory bytes handed to zlib or copied so far
  // Inflate state.
  std::vector<std::uint8_t> input;
  z_stream zs{};
  bool zs_ready = false;
  bool at_member_start = true;  // the next compressed byte starts a stream (or a member)
  bool first_member = true;
  bool finished = false;
  std::uint64_t position = 0;
  // libdeflate fast path (gzip only): whole members decoded into `fast_out`, served from there.
  libdeflate_decompressor* fast = nullptr;
  std::vector<std::uint8_t> fast_out;
  std::size_t fast_pos = 0, fast_len = 0;

  ~Impl() {
    if (zs_ready) inflateEnd(&zs);
    if (fast != nullptr) libdeflate_free_decompressor(fast);
    if (fd >= 0) ::close(fd);
  }

  void init_inflate() {
    if (compression == Compression::none) return;
    // 16+15: gzip only; 32+15: zlib or gzip, detected from the header.
    const int window_bits = compression == Compression::gzip ? 16 + 15 : 32 + 15;
    if (inflateInit2(&zs, window_bits) != Z_OK)
      throw ResourceError(what + ": cannot initialise zlib");
    zs_ready = true;
    if (compression == Compression::gzip) fast = libdeflate_alloc_decompressor();
    if (fd >= 0) input.resize(fast != nullptr ? kFastWindowBytes : kInputBufferBytes);
  }

  std::size_t read_raw(std::uint8_t* dst, std::size_t n) {
    if (fd < 0) {
      const std::size_t got = std::min(n, memory.size() - memory_pos);
      std::memcpy(dst, memory.data() + memory_pos, got);
      memory_pos += got;
      return got;
    }
    return read_fully(fd, dst, n, what);
  }

  // Appends more compressed input after what zlib has not consumed yet; false at end of input.
  bool refill() {
    if (fd < 0) {
      // Memory is contiguous: extend the window zlib sees.
      const std::size_t add = std::min(memory.size() - memory_pos, kMaxZlibChunk - zs.avail_in);
      if (add == 0) return false;
      if (zs.avail_in == 0) zs.next_in = const_cast<Bytef*>(memory.data() + memory_pos);
      zs.avail_in += static_cast<uInt>(add);
      memory_pos += add;
      return true;
    }
    const std::size_t kept = zs.avail_in;
    if (kept > 0) std::memmove(input.data(), zs.next_in, kept);
    const std::size_t got = read_fully(fd, input.data() + kept, input.size() - kept, what);
    zs.next_in = input.data();
    zs.avail_in = static_cast<uInt>(kept + got);
    return got > 0;
  }

  // After a gzip member ended: does another member follow (magic 1f 8b)? Anything else after
  // the last member (padding, trailing garbage) is ignored, as gzip(1) does.
  bool next_member_follows() {
    while (zs.avail_in < 2 && refill()) {
    }
    return zs.avail_in >= 2 && zs.next_in[0] == 0x1f && zs.next_in[1] == 0x8b;
  }

  // Tops the window up to kFastWindowBytes of unconsumed input (a file's buffer holds that much
  // while the fast path is on; memory is extended in place).
  void fill_window() {
    while (zs.avail_in < kFastWindowBytes && refill()) {
    }
  }

  // Decodes the member at the window's start with libdeflate (it checks the CRC and length).
  // False, with nothing consumed, when it cannot (a member larger than the window or the
  // buffer, or damaged data): zlib then decodes that member and the fast path stays off, so
  // errors keep zlib's messages and a foreign file costs at most one wasted attempt.
  bool try_fast_member() {
    fill_window();
    if (zs.avail_in < 18) return false;  // shorter than any gzip member: let zlib say why
    if (fast_out.empty()) fast_out.resize(kFastMemberBytes);
    std::size_t used = 0, produced = 0;
    const libdeflate_result rc = libdeflate_gzip_decompress_ex(
        fast, zs.next_in, std::min<std::size_t>(zs.avail_in, kFastWindowBytes), fast_out.data(),
        fast_out.size(), &used, &produced);
    if (rc != LIBDEFLATE_SUCCESS) {
      libdeflate_free_decompressor(fast);
      fast = nullptr;
      fast_out = {};
      return false;
    }
    zs.next_in += used;
    zs.avail_in -= static_cast<uInt>(used);
    fast_pos = 0;
    fast_len = produced;
    return true;
  }

  [[noreturn]] void throw_truncated() const {
    throw InputError(what + ": truncated " + stream_name(compression) +
                     " stream (file ends before the compressed data does)");
  }

  [[noreturn]] void throw_corrupt(int rc) const {
    if (rc == Z_MEM_ERROR) throw ResourceError(what + ": out of memory while decompressing");
    const char* detail = zs.msg != nullptr ? zs.msg : "invalid data";
    throw InputError(what + ": corrupt " + stream_name(compression) + " data (zlib: " + detail +
                     ")");
  }

  std::size_t read_inflated(std::uint8_t* dst, std::size_t n) {
    std::size_t done = 0;
    while (done < n && !finished) {
      if (fast_pos < fast_len) {
        const std::size_t take = std::min(n - done, fast_len - fast_pos);
        std::memcpy(dst + done, fast_out.data() + fast_pos, take);
        fast_pos += take;
        done += take;
        continue;
      }
      if (at_member_start) {
        // After a gzip member: another follows when the magic 1f 8b does. Anything else after
        // the last member (padding, trailing garbage) is ignored, as gzip(1) does.
        if (!first_member && !(compression == Compression::gzip && next_member_follows())) {
          finished = true;
          break;
        }
        first_member = false;
        if (fast != nullptr && try_fast_member()) continue;
        inflateReset(&zs);
        at_member_start = false;
      }
      if (zs.avail_in == 0 && !refill()) throw_truncated();
      const std::size_t want = std::min(n - done, kMaxZlibChunk);
      zs.next_out = dst + done;
      zs.avail_out = static_cast<uInt>(want);
      const uInt in_before = zs.avail_in;
      const int rc = inflate(&zs, Z_NO_FLUSH);
      const std::size_t produced = want - zs.avail_out;
      done += produced;
      if (rc == Z_STREAM_END) {
        at_member_start = true;
      } else if (rc == Z_BUF_ERROR) {
        // No progress possible: zlib needs more input (refilled at the top of the loop).
        if (zs.avail_in != 0 && produced == 0 && zs.avail_in == in_before) throw_corrupt(rc);
      } else if (rc != Z_OK) {
        throw_corrupt(rc);
      }
    }
    return done;
  }

  std::size_t read(std::uint8_t* dst, std::size_t n) {
    const std::size_t got =
        compression == Compression::none ? read_raw(dst, n) : read_inflated(dst, n);
    position += got;
    return got;
  }

  std::uint64_t skip(std::uint64_t n) {
    if (compression == Compression::none) {
      std::uint64_t skipped = 0;
      if (fd < 0) {
        skipped = std::min<std::uint64_t>(n, memory.size() - memory_pos);
        memory_pos += static_cast<std::size_t>(skipped);
      } else {
        const std::uint64_t here = raw_offset + position;
        skipped = here >= file_bytes ? 0 : std::min<std::uint64_t>(n, file_bytes - here);
        if (::lseek(fd, static_cast<off_t>(here + skipped), SEEK_SET) < 0)
          throw InputError(what + ": seek error (" + errno_text(errno) + ")");
      }
      position += skipped;
      return skipped;
    }
    std::vector<std::uint8_t> scratch(std::min<std::uint64_t>(n, 1 << 16));
    std::uint64_t skipped = 0;
    while (skipped < n) {
      const std::size_t want =
          static_cast<std::size_t>(std::min<std::uint64_t>(n - skipped, scratch.size()));
      const std::size_t got = read(scratch.data(), want);
      skipped += got;
      if (got < want) break;
    }
    return skipped;
  }
};

DecodedReader::DecodedReader(const std::string& path, std::uint64_t offset, Compression compression)
    : impl_(std::make_unique<Impl>()) {
  impl_->what = path;
  impl_->compression = compression;
  impl_->fd = open_for_reading(path);
  struct stat info {};
  if (::fstat(impl_->fd, &info) != 0)
    throw InputError(path + ": cannot examine (" + errno_text(errno) + ")");
  impl_->file_bytes = static_cast<std::uint64_t>(info.st_size);
  impl_->raw_offset = offset;
  if (::lseek(impl_->fd, static_cast<off_t>(offset), SEEK_SET) < 0)
    throw InputError(path + ": seek error (" + errno_text(errno) + ")");
  impl_->init_inflate();
}

DecodedReader::DecodedReader(ByteSpan bytes, Compression compression, const std::string& what)
    : impl_(std::make_unique<Impl>()) {
  impl_->what = what;
  impl_->compression = compression;
  impl_->memory = bytes;
  impl_->init_inflate();
}

DecodedReader::~DecodedReader() = default;

std::size_t DecodedReader::read(void* dst, std::size_t n) {
  return impl_->read(static_cast<std::uint8_t*>(dst), n);
}

std::uint64_t DecodedReader::skip(std::uint64_t n) {
  return impl_->skip(n);
}

std::uint64_t DecodedReader::position() const {
  return impl_->position;
}

// ---------------------------------------------------------------------------------------------
// Whole-file helpers

std::uint64_t file_size(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) throw_open_error(path, errno);
  if (!S_ISREG(info.st_mode))
    throw InputError(path + ": " + kind_of(info.st_mode) +
                     ", not a regular file: palp reads files only");
  return static_cast<std::uint64_t>(info.st_size);
}

void require_regular_file(const std::string& path) {
  (void)file_size(path);
}

bool file_is_gzip(const std::string& path) {
  const int fd = open_for_reading(path);
  std::uint8_t magic[2] = {0, 0};
  std::size_t got = 0;
  try {
    got = read_fully(fd, magic, 2, path);
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
  return got == 2 && magic[0] == 0x1f && magic[1] == 0x8b;
}

namespace {

// Reads everything `reader` yields, refusing more than max_bytes.
std::vector<std::uint8_t> read_all(DecodedReader& reader, std::size_t max_bytes,
                                   const std::string& what) {
  std::vector<std::uint8_t> out;
  std::size_t chunk = std::size_t{1} << 16;
  for (;;) {
    const std::size_t old_size = out.size();
    const std::size_t want = std::min(chunk, max_bytes - old_size + 1);  // +1 detects overflow
    out.resize(old_size + want);
    const std::size_t got = reader.read(out.data() + old_size, want);
    out.resize(old_size + got);
    if (out.size() > max_bytes)
      throw InputError(what + ": decompressed content exceeds the limit of " +
                       std::to_string(max_bytes) + " bytes");
    if (got < want) return out;
    chunk = std::min(chunk * 2, std::size_t{64} << 20);
  }
}

}  // namespace

std::vector<std::uint8_t> read_file(const std::string& path, std::size_t max_bytes) {
  if (file_is_gzip(path)) {
    DecodedReader reader(path, 0, Compression::gzip);
    return read_all(reader, max_bytes, path);
  }
  const std::uint64_t size = file_size(path);
  if (size > max_bytes)
    throw InputError(path + ": file of " + std::to_string(size) + " bytes exceeds the limit of " +
                     std::to_string(max_bytes) + " bytes");
  DecodedReader reader(path, 0, Compression::none);
  std::vector<std::uint8_t> out(static_cast<std::size_t>(size));
  out.resize(reader.read(out.data(), out.size()));
  return out;
}

std::vector<std::uint8_t> decompress(ByteSpan bytes, Compression compression, std::size_t max_bytes,
                                     const std::string& what) {
  DecodedReader reader(bytes, compression, what);
  return read_all(reader, max_bytes, what);
}

// ---------------------------------------------------------------------------------------------
// Parallel gzip compression

namespace {

// ISA-L's AVX2 / AVX-512 kernels return without VZEROUPPER (libisal 2.30 has none): the calling
// thread's SSE code afterwards (the distance maps, on the thread that wrote the previous map)
// then ran up to several times slower on the development VM. Clearing the upper halves ends that.
void clear_upper_vector_state() {
#if defined(__x86_64__)
  static const bool has_avx = __builtin_cpu_supports("avx");
  if (has_avx) __asm__ volatile("vzeroupper" ::: "memory");
#endif
}

// One gzip member per call, by ISA-L's igzip (about 4x faster than libdeflate's level 1 on
// palp's float maps, within a point of its size); libdeflate when igzip cannot (it never should:
// the buffer holds stored blocks of any input).
class MemberCompressor {
 public:
  explicit MemberCompressor(int level) : level_(std::clamp(level, 0, 3)) {
    const std::size_t level_bytes[4] = {ISAL_DEF_LVL0_DEFAULT, ISAL_DEF_LVL1_DEFAULT,
                                        ISAL_DEF_LVL2_DEFAULT, ISAL_DEF_LVL3_DEFAULT};
    level_buffer_.resize(level_bytes[level_]);
  }

  // Compresses `in` as one gzip member into `scratch` and returns an exact-size copy.
  std::vector<std::uint8_t> member(ByteSpan in, std::vector<std::uint8_t>& scratch) {
    // Stored blocks cost 5 bytes per 64 KiB; the gzip header and trailer 18.
    scratch.resize(in.size() + in.size() / 1024 + 4096);
    // Every member starts from zeroed state: igzip's hash tables would otherwise keep entries of
    // the member this thread compressed before, and the bytes (not their meaning) would depend
    // on which thread took which member.
    std::fill(level_buffer_.begin(), level_buffer_.end(), std::uint8_t{0});
    isal_zstream stream{};
    isal_deflate_stateless_init(&stream);
    stream.level = static_cast<std::uint32_t>(level_);
    stream.level_buf = level_buffer_.data();
    stream.level_buf_size = static_cast<std::uint32_t>(level_buffer_.size());
    // Members a reader may decode in parallel carry their length (gzip_index.hpp): igzip writes
    // the deflate data and the trailer, the header with the length goes in front.
    const bool indexed = in.size() <= kMaxIndexedMemberInput;
    const std::size_t header = indexed ? kIndexedHeaderBytes : 0;
    stream.gzip_flag = indexed ? IGZIP_GZIP_NO_HDR : IGZIP_GZIP;
    stream.end_of_stream = 1;
    stream.flush = NO_FLUSH;
    stream.next_in = const_cast<std::uint8_t*>(in.data());
    stream.avail_in = static_cast<std::uint32_t>(in.size());
    stream.next_out = scratch.data() + header;
    stream.avail_out = static_cast<std::uint32_t>(scratch.size() - header);
    std::size_t n = 0;
    const int rc = isal_deflate_stateless(&stream);
    clear_upper_vector_state();
    if (rc == COMP_OK) {
      n = header + stream.total_out;
      if (indexed) write_indexed_header(scratch.data(), static_cast<std::uint32_t>(n));
    } else {
      n = libdeflate_member(in, scratch);
    }
    return {scratch.begin(), scratch.begin() + static_cast<std::ptrdiff_t>(n)};
  }

 private:
  std::size_t libdeflate_member(ByteSpan in, std::vector<std::uint8_t>& scratch) {
    libdeflate_compressor* compressor = libdeflate_alloc_compressor(1);
    if (compressor == nullptr) throw ResourceError("cannot allocate a gzip compressor");
    scratch.resize(libdeflate_gzip_compress_bound(compressor, in.size()));
    const std::size_t n =
        libdeflate_gzip_compress(compressor, in.data(), in.size(), scratch.data(), scratch.size());
    libdeflate_free_compressor(compressor);
    if (n == 0) throw ResourceError("gzip compression failed");
    return n;
  }

  int level_;
  std::vector<std::uint8_t> level_buffer_;
};

// Splits the pieces into member-sized spans; at least one (possibly empty) member.
std::vector<ByteSpan> split_into_members(std::span<const ByteSpan> pieces,
                                         std::size_t member_bytes) {
  member_bytes = std::max<std::size_t>(member_bytes, 1);
  std::vector<ByteSpan> members;
  for (const ByteSpan& piece : pieces) {
    for (std::size_t at = 0; at < piece.size(); at += member_bytes)
      members.push_back(piece.subspan(at, std::min(member_bytes, piece.size() - at)));
  }
  if (members.empty()) members.emplace_back();
  return members;
}

// Compresses `inputs[first, last)` in parallel, one output per member.
std::vector<std::vector<std::uint8_t>> compress_members(const std::vector<ByteSpan>& inputs,
                                                        std::size_t first, std::size_t last,
                                                        const GzipOptions& options) {
  std::vector<std::vector<std::uint8_t>> outputs(last - first);
  parallel_for_chunks(
      static_cast<std::int64_t>(outputs.size()), 1,
      [&](std::int64_t begin, std::int64_t end) {
        MemberCompressor compressor(options.level);
        std::vector<std::uint8_t> scratch;
        for (std::int64_t m = begin; m < end; ++m) {
          const auto index = static_cast<std::size_t>(m);
          outputs[index] = compressor.member(inputs[first + index], scratch);
        }
      },
      std::max(options.threads, 1u));
  return outputs;
}

// A file written under a temporary name and renamed into place by commit().
class AtomicFileWriter {
 public:
  explicit AtomicFileWriter(const std::string& path) : path_(path) {
    static std::atomic<unsigned> counter{0};
    temp_ = path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
    fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd_ < 0) fail(errno);
  }
  ~AtomicFileWriter() {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_) ::unlink(temp_.c_str());
  }
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  void write(ByteSpan bytes) {
    std::size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n =
          ::write(fd_, bytes.data() + done, std::min(bytes.size() - done, kMaxZlibChunk));
      if (n < 0) {
        if (errno == EINTR) continue;
        fail(errno);
      }
      done += static_cast<std::size_t>(n);
    }
  }

  void commit() {
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) fail(errno);
    if (::rename(temp_.c_str(), path_.c_str()) != 0) fail(errno);
    committed_ = true;
  }

 private:
  [[noreturn]] void fail(int error) const {
    throw ResourceError("cannot write " + path_ + " (" + errno_text(error) + ")");
  }

  std::string path_;
  std::string temp_;
  int fd_ = -1;
  bool committed_ = false;
};

}  // namespace

std::vector<std::uint8_t> gzip_compress(std::span<const ByteSpan> pieces,
                                        const GzipOptions& options) {
  const std::vector<ByteSpan> inputs = split_into_members(pieces, options.member_bytes);
  const auto members = compress_members(inputs, 0, inputs.size(), options);
  std::size_t total = 0;
  for (const auto& m : members) total += m.size();
  std::vector<std::uint8_t> out;
  out.reserve(total);
  for (const auto& m : members) out.insert(out.end(), m.begin(), m.end());
  return out;
}

void write_file(const std::string& path, std::span<const ByteSpan> pieces, bool gzip,
                const GzipOptions& options) {
  AtomicFileWriter file(path);
  if (gzip) {
    // A few members per thread at a time: the compressed bytes in memory stay bounded (a few
    // MiB per thread), not the whole file's.
    const std::vector<ByteSpan> inputs = split_into_members(pieces, options.member_bytes);
    const std::size_t batch = 4 * std::max<std::size_t>(options.threads, 1);
    for (std::size_t first = 0; first < inputs.size(); first += batch) {
      const std::size_t last = std::min(inputs.size(), first + batch);
      for (const auto& member : compress_members(inputs, first, last, options)) file.write(member);
    }
  } else {
    for (const ByteSpan& piece : pieces) file.write(piece);
  }
  file.commit();
}

}  // namespace palp
