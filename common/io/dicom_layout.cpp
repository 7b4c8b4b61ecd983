// The element walk of dicom_layout.hpp.
#include "io/dicom_layout.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "base/errors.hpp"
#include "io/gzip.hpp"

namespace palp {
namespace {

constexpr std::size_t kWindowBytes = std::size_t{1} << 16;
// Strings the walk keeps (UIDs) are at most 64 characters.
constexpr std::uint32_t kMaxTextBytes = 64;

bool long_length_vr(const char vr[2]) {
  static const char* const kLong[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ",
                                      "SV", "UC", "UN", "UR", "UT", "UV"};
  for (const char* l : kLong)
    if (vr[0] == l[0] && vr[1] == l[1]) return true;
  return false;
}

std::string hex_tag(std::uint32_t tag) {
  static const char* const kDigits = "0123456789abcdef";
  std::string out = "(0000,0000)";
  for (int n = 0; n < 8; ++n) {
    const char digit = kDigits[(tag >> (28 - 4 * n)) & 0xf];
    out[static_cast<std::size_t>(n < 4 ? 1 + n : 2 + n)] = digit;
  }
  return out;
}

}  // namespace

DicomLayoutCheck::DicomLayoutCheck(std::vector<char> bytes)
    : bytes_(std::move(bytes)), size_(bytes_.size()) {}

DicomLayoutCheck::DicomLayoutCheck(const std::string& path) {
  require_regular_file(path);
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (fd_ < 0) throw InputError(path + ": cannot open (" + std::strerror(errno) + ")");
  struct stat info {};
  if (::fstat(fd_, &info) != 0 || !S_ISREG(info.st_mode)) {
    ::close(fd_);
    fd_ = -1;
    throw InputError(path + ": not a regular file: palp reads files only");
  }
  size_ = static_cast<std::uint64_t>(info.st_size);
  window_.resize(kWindowBytes);
}

DicomLayoutCheck::~DicomLayoutCheck() {
  if (fd_ >= 0) ::close(fd_);
}

void DicomLayoutCheck::fetch(std::uint64_t at, std::size_t n, char* dst) {
  if (fd_ < 0) {
    std::memcpy(dst, bytes_.data() + at, n);
    return;
  }
  if (at < window_at_ || at + n > window_at_ + window_size_) {
    window_at_ = at;
    window_size_ = 0;
    while (window_size_ < n) {  // n <= kMaxTextBytes < kWindowBytes
      const ssize_t got = ::pread(fd_, window_.data() + window_size_, window_.size() - window_size_,
                                  static_cast<off_t>(at + window_size_));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) break;  // the file shrank under us: the bytes read as zeros
      window_size_ += static_cast<std::size_t>(got);
    }
    if (window_size_ < n)
      std::fill(window_.begin() + static_cast<std::ptrdiff_t>(window_size_),
                window_.begin() + static_cast<std::ptrdiff_t>(n), '\0');
    window_size_ = std::max(window_size_, n);
  }
  std::memcpy(dst, window_.data() + (at - window_at_), n);
}

std::uint32_t DicomLayoutCheck::read_uint(std::uint64_t at, int size) {
  unsigned char bytes[4] = {0, 0, 0, 0};
  fetch(at, static_cast<std::size_t>(size), reinterpret_cast<char*>(bytes));
  std::uint32_t v = 0;
  for (int b = 0; b < size; ++b)
    v |= static_cast<std::uint32_t>(bytes[b]) << (8 * (big_endian_ ? size - 1 - b : b));
  return v;
}

std::string DicomLayoutCheck::read_text(std::uint64_t at, std::uint32_t length) {
  std::string text(std::min(length, kMaxTextBytes), '\0');
  fetch(at, text.size(), text.data());
  while (!text.empty() && (text.back() == '\0' || text.back() == ' ')) text.pop_back();
  return text;
}

// Reads an element header at pos_ and moves past it; false when it does not fit.
bool DicomLayoutCheck::header(Header& h) {
  if (!fits(8)) return false;
  ++elements_;
  h.group = static_cast<std::uint16_t>(read_uint(pos_, 2));
  h.element = static_cast<std::uint16_t>(read_uint(pos_ + 2, 2));
  h.vr[0] = h.vr[1] = 0;
  if (h.group == 0xfffe || !explicit_vr_) {  // items and delimiters are always implicit
    h.length = read_uint(pos_ + 4, 4);
    pos_ += 8;
    return true;
  }
  fetch(pos_ + 4, 2, h.vr);
  if (!long_length_vr(h.vr)) {
    h.length = read_uint(pos_ + 6, 2);
    pos_ += 8;
    return true;
  }
  if (!fits(12)) return false;
  h.length = read_uint(pos_ + 8, 4);
  pos_ += 12;
  return true;
}

bool DicomLayoutCheck::skip(std::uint32_t length) {
  if (!fits(length)) return false;
  pos_ += length;
  return true;
}

DicomLayoutCheck::Result DicomLayoutCheck::refuse(const std::string& why) {
  reason_ = why;
  return Result::refused;
}

DicomLayoutCheck::Result DicomLayoutCheck::run() {
  pos_ = 132;  // preamble + "DICM"
  if (size_ < pos_) return Result::truncated;
  const Result meta = walk_file_meta();
  if (meta != Result::complete) return meta;
  const Result data = walk_dataset(false, 0);
  if (data == Result::complete && size_ - pixel_data_bytes_ > kMaxHeaderBytes)
    return refuse(std::to_string(size_ - pixel_data_bytes_) +
                  " bytes besides the pixel data, more than the limit of " +
                  std::to_string(kMaxHeaderBytes));
  return data;
}

// Group 0002 is explicit VR little endian; it names the data set's transfer syntax.
DicomLayoutCheck::Result DicomLayoutCheck::walk_file_meta() {
  big_endian_ = false;
  explicit_vr_ = true;
  Header h;
  while (fits(2) && read_uint(pos_, 2) == 0x0002) {
    if (!header(h)) return Result::truncated;
    if (h.length == kUndefined) return Result::unsure;
    if (!fits(h.length)) return Result::truncated;
    if (h.element == 0x0010) syntax_ = read_text(pos_, h.length);
    if (h.element == 0x0002) sop_class_ = read_text(pos_, h.length);
    if (!skip(h.length)) return Result::truncated;
  }
  if (syntax_ == "1.2.840.10008.1.2.1.99") return Result::unsure;  // deflated data set
  explicit_vr_ = syntax_ != "1.2.840.10008.1.2";
  big_endian_ = syntax_ == "1.2.840.10008.1.2.2";
  return Result::complete;
}

// Elements up to the end of the file, or (inside an item) up to the item delimiter.
DicomLayoutCheck::Result DicomLayoutCheck::walk_dataset(bool in_item, int depth) {
  if (depth > kMaxDepth)
    return refuse("sequences nested more than " + std::to_string(kMaxDepth) + " deep");
  Header h;
  std::int64_t previous = -1;
  while (pos_ < size_) {
    const std::uint64_t at = pos_;
    if (!header(h)) return Result::truncated;
    if (elements_ > kMaxElements)
      return refuse("more than " + std::to_string(kMaxElements) + " elements");
    if (h.group == 0xfffe && h.element == 0xe00d) return Result::complete;  // end of item
    const std::uint32_t tag = std::uint32_t{h.group} << 16 | h.element;
    if (static_cast<std::int64_t>(tag) <= previous)
      return refuse("element " + hex_tag(tag) + " at byte " + std::to_string(at) +
                    " does not follow " + hex_tag(static_cast<std::uint32_t>(previous)) +
                    " in tag order");
    previous = tag;
    const bool pixel_data = !in_item && tag == 0x7fe00010u;
    if (h.length != kUndefined) {
      if (!skip(h.length)) return Result::truncated;
      if (pixel_data) {
        has_pixel_data_ = true;
        pixel_data_bytes_ = h.length;
      }
      continue;
    }
    const Result r = walk_undefined_sequence(h, pixel_data, depth);
    if (r != Result::complete) return r;
    has_pixel_data_ = has_pixel_data_ || pixel_data;
  }
  return in_item ? Result::truncated : Result::complete;
}

// A sequence (or encapsulated pixel data) of undefined length: items up to the delimiter.
DicomLayoutCheck::Result DicomLayoutCheck::walk_undefined_sequence(const Header& owner,
                                                                   bool pixel_data, int depth) {
  const bool saved_explicit = explicit_vr_;
  if (owner.vr[0] == 'U' && owner.vr[1] == 'N') explicit_vr_ = false;  // UN: implicit inside
  Header h;
  Result result = Result::truncated;
  while (header(h)) {
    if (elements_ > kMaxElements) {
      result = refuse("more than " + std::to_string(kMaxElements) + " elements");
      break;
    }
    if (h.group == 0xfffe && h.element == 0xe0dd) {
      result = Result::complete;
      break;
    }
    if (h.group != 0xfffe || h.element != 0xe000) {
      result = Result::unsure;
      break;
    }
    if (h.length == kUndefined) {
      result = walk_dataset(true, depth + 1);
      if (result != Result::complete) break;
      result = Result::truncated;
    } else if (!skip(h.length)) {
      break;
    } else if (pixel_data) {
      pixel_data_bytes_ += h.length;
    }
  }
  explicit_vr_ = saved_explicit;
  return result;
}

}  // namespace palp
