// Gzip members that say how long they are, and reading them in parallel.
//
// palp's gzip writer (gzip.hpp) emits independent members of about 4 MiB of input. Each carries
// its own compressed length in an extra field of its header (RFC 1952 FEXTRA, subfield "PZ",
// 4 bytes little-endian, the whole member's length), as BGZF does with its "BC" subfield: a
// reader then finds every member from the headers alone and decodes them on all cores. Other
// gzip readers skip the field (the files stay plain gzip).
//
// read_indexed_gzip() is the fast path of the volume readers (ct_io.cpp): it takes a file only
// when every member, up to its exact end, carries the field; anything else (a foreign file, a
// damaged member, trailing bytes) returns false having delivered nothing, and the streaming
// reader (DecodedReader) reads it as before, with its messages.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace palp {

// Bytes of the header written before each member's deflate data.
inline constexpr std::size_t kIndexedHeaderBytes = 20;

// Writes the header of a member whose total length (this header, the deflate data and the 8-byte
// trailer) is `member_bytes`.
void write_indexed_header(std::uint8_t* out, std::uint32_t member_bytes);

// Decodes the decoded bytes [first, first + count) of the gzip file at `path`, member by member
// on up to `threads` threads, handing each piece to `deliver(offset - first, bytes, size)` (from
// any of those threads; pieces never overlap). Every member delivered has passed its CRC and
// length check. Pieces start at member boundaries (the first at `first`) and are multiples of
// `granule` bytes long except the last. Returns false, having delivered nothing, when the file
// is not wholly made of indexed members, its members do not fall on granules, or it decodes to
// less than first + count; and false, with what was delivered to be discarded, when a member
// turns out damaged. A member may claim at most 1032 decoded bytes per compressed byte (deflate's
// limit) and 64 MiB, so nothing claimed is allocated beyond what the file can hold.
// `prepare()` is called once, before the first piece, when the members' lengths show that the
// file holds the bytes (the caller allocates there, not before).
bool read_indexed_gzip(
    const std::string& path, std::uint64_t first, std::uint64_t count, std::size_t granule,
    unsigned threads, const std::function<void()>& prepare,
    const std::function<void(std::uint64_t, const std::uint8_t*, std::size_t)>& deliver);

}  // namespace palp
