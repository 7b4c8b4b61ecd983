// File bytes with transparent decompression, and fast gzip writing.
//
// Reading: DecodedReader streams a file (from any offset) as raw bytes, a gzip stream (several
// concatenated members allowed) or a zlib stream. Gzip members up to 8 MiB (palp's own files)
// are decoded whole by libdeflate (2-3x faster than zlib); a larger or damaged member, and every
// member after it, goes through zlib's streaming inflate, whose messages the errors carry.
// Truncated and corrupt streams throw InputError naming the file.
//
// Writing: gzip output is a concatenation of independent members of about 4 MiB of input each,
// compressed in parallel with ISA-L's igzip at level 1 (on palp's float maps 4x faster than
// libdeflate's level 1, files 1-1.5 points of the raw size larger) and written a batch at a time
// (the compressed bytes in memory stay a few MiB per thread). A multi-member gzip file is valid
// gzip (RFC 1952) and is read by zlib, gzip, ITK and nibabel.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "base/parallel.hpp"

namespace palp {

enum class Compression {
  none,  // raw bytes
  gzip,  // RFC 1952, one or more members
  zlib,  // RFC 1950 (MetaImage CompressedData); a gzip header is accepted too
};

using ByteSpan = std::span<const std::uint8_t>;

// Sequential reader of decoded bytes. `what` names the source in error messages (the path).
class DecodedReader {
 public:
  // Reads the file at `path` from byte `offset` on.
  DecodedReader(const std::string& path, std::uint64_t offset, Compression compression);
  // Reads bytes held in memory (they must outlive the reader).
  DecodedReader(ByteSpan bytes, Compression compression, const std::string& what);
  ~DecodedReader();
  DecodedReader(const DecodedReader&) = delete;
  DecodedReader& operator=(const DecodedReader&) = delete;

  // Reads up to `n` decoded bytes into `dst`; returns fewer only at the end of the data.
  std::size_t read(void* dst, std::size_t n);
  // Discards up to `n` decoded bytes; returns how many were discarded.
  std::uint64_t skip(std::uint64_t n);
  // Decoded bytes delivered or skipped so far.
  std::uint64_t position() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Size of a regular file in bytes; InputError when it cannot be examined.
std::uint64_t file_size(const std::string& path);
// InputError unless `path` (after symlinks) is a regular file: a FIFO, a device, a directory or
// a socket would block or never end, a symlink loop is named as one. Checked before opening.
void require_regular_file(const std::string& path);

// True when the file starts with the gzip magic bytes 1f 8b.
bool file_is_gzip(const std::string& path);

// Reads a whole file, gunzipping it when it starts with the gzip magic. Throws InputError when
// the (decompressed) content would exceed `max_bytes`.
std::vector<std::uint8_t> read_file(const std::string& path, std::size_t max_bytes);

// Decodes an in-memory gzip or zlib stream; InputError past `max_bytes` of output.
std::vector<std::uint8_t> decompress(ByteSpan bytes, Compression compression, std::size_t max_bytes,
                                     const std::string& what);

struct GzipOptions {
  int level = 1;                                    // ISA-L igzip level 0..3
  std::size_t member_bytes = std::size_t{4} << 20;  // input bytes per gzip member
  unsigned threads = default_thread_count();
};

// Gzip-compresses the concatenation of `pieces` (each piece starts a new member).
std::vector<std::uint8_t> gzip_compress(std::span<const ByteSpan> pieces,
                                        const GzipOptions& options = {});
inline std::vector<std::uint8_t> gzip_compress(ByteSpan bytes, const GzipOptions& options = {}) {
  return gzip_compress(std::span<const ByteSpan>(&bytes, 1), options);
}

// Writes the concatenation of `pieces` to `path` (gzip-compressed when `gzip`), through a
// temporary file in the same directory renamed into place. Throws ResourceError on failure.
void write_file(const std::string& path, std::span<const ByteSpan> pieces, bool gzip,
                const GzipOptions& options = {});

}  // namespace palp
