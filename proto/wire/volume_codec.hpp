// The render volume's byte fields on the wire: zlib streams (libdeflate) both ends share.
// Bounded: decompression writes exactly the size the receiver expects from the chunk's
// dimensions and refuses any stream that would give more or fewer bytes.
#pragma once

#include <cstddef>
#include <string>

namespace palp::wire {

// `raw` as a zlib stream (libdeflate level 1: fast, a CT's air and masks compress well).
std::string deflate_bytes(const std::string& raw);

// The zlib stream `packed` inflated to exactly `expected` bytes into `out`; false (out
// unspecified) when the stream is corrupt or does not hold exactly `expected` bytes.
bool inflate_exact(const std::string& packed, std::size_t expected, std::string& out);

}  // namespace palp::wire
