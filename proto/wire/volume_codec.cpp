// zlib streams for render-volume chunks: see volume_codec.hpp.
#include "wire/volume_codec.hpp"

#include <libdeflate.h>

#include <memory>
#include <new>

namespace palp::wire {

namespace {
struct CompressorFree {
  void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
};
struct DecompressorFree {
  void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
};
}  // namespace

std::string deflate_bytes(const std::string& raw) {
  const std::unique_ptr<libdeflate_compressor, CompressorFree> c(libdeflate_alloc_compressor(1));
  if (!c) throw std::bad_alloc();
  std::string out(libdeflate_zlib_compress_bound(c.get(), raw.size()), '\0');
  const std::size_t n =
      libdeflate_zlib_compress(c.get(), raw.data(), raw.size(), out.data(), out.size());
  out.resize(n);
  return out;
}

bool inflate_exact(const std::string& packed, std::size_t expected, std::string& out) {
  const std::unique_ptr<libdeflate_decompressor, DecompressorFree> d(
      libdeflate_alloc_decompressor());
  if (!d) throw std::bad_alloc();
  out.resize(expected);
  std::size_t got = 0;
  const libdeflate_result r = libdeflate_zlib_decompress(d.get(), packed.data(), packed.size(),
                                                         out.data(), out.size(), &got);
  return r == LIBDEFLATE_SUCCESS && got == expected;
}

}  // namespace palp::wire
