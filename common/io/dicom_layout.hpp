// A structural check of DICOM Part 10 files: GDCM reads a file whose last element is cut short
// (a truncated transfer) as if it were whole, so the DICOM reader first walks the elements to
// check that each one lies within the file.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace palp {

// Walks the elements of a Part 10 file (little or big endian, explicit or implicit VR, nested
// sequences and encapsulated pixel data) only to check that each one lies within the file.
class DicomLayoutCheck {
 public:
  enum class Result { complete, truncated, unsure };

  explicit DicomLayoutCheck(std::vector<char> bytes) : bytes_(std::move(bytes)) {}

  Result run() {
    pos_ = 132;  // preamble + "DICM"
    const auto meta = walk_file_meta();
    if (meta != Result::complete) return meta;
    return walk_dataset(false);
  }

  // After run(): the SOP class the file meta names, and whether the top-level data set holds a
  // whole Pixel Data element. A file cut exactly at an element boundary walks as complete; only
  // an image class without its pixels then shows the cut.
  const std::string& media_storage_sop_class() const { return sop_class_; }
  bool has_pixel_data() const { return has_pixel_data_; }

 private:
  static constexpr std::uint32_t kUndefined = 0xffffffffu;
  struct Header {
    std::uint16_t group = 0, element = 0;
    std::uint32_t length = 0;
    char vr[2] = {0, 0};
  };

  bool fits(std::size_t n) const { return pos_ <= bytes_.size() && n <= bytes_.size() - pos_; }

  std::uint32_t read_uint(std::size_t at, int size) const {
    std::uint32_t v = 0;
    for (int b = 0; b < size; ++b) {
      const auto byte = static_cast<std::uint8_t>(bytes_[at + static_cast<std::size_t>(b)]);
      v |= static_cast<std::uint32_t>(byte) << (8 * (big_endian_ ? size - 1 - b : b));
    }
    return v;
  }

  static bool long_length_vr(const char vr[2]) {
    static const char* const kLong[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ",
                                        "SV", "UC", "UN", "UR", "UT", "UV"};
    for (const char* l : kLong)
      if (vr[0] == l[0] && vr[1] == l[1]) return true;
    return false;
  }

  // Reads an element header at pos_ and moves past it; false when it does not fit.
  bool header(Header& h) {
    if (!fits(8)) return false;
    h.group = static_cast<std::uint16_t>(read_uint(pos_, 2));
    h.element = static_cast<std::uint16_t>(read_uint(pos_ + 2, 2));
    if (h.group == 0xfffe || !explicit_vr_) {  // items and delimiters are always implicit
      h.length = read_uint(pos_ + 4, 4);
      pos_ += 8;
      return true;
    }
    h.vr[0] = bytes_[pos_ + 4];
    h.vr[1] = bytes_[pos_ + 5];
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

  bool skip(std::uint32_t length) {
    if (!fits(length)) return false;
    pos_ += length;
    return true;
  }

  // Group 0002 is explicit VR little endian; it names the data set's transfer syntax.
  Result walk_file_meta() {
    std::string syntax;
    Header h;
    while (fits(2) && read_uint(pos_, 2) == 0x0002) {
      if (!header(h)) return Result::truncated;
      if (h.length == kUndefined) return Result::unsure;
      if (h.element == 0x0010 && fits(h.length)) syntax.assign(&bytes_[pos_], h.length);
      if (h.element == 0x0002 && fits(h.length)) sop_class_.assign(&bytes_[pos_], h.length);
      if (!skip(h.length)) return Result::truncated;
    }
    while (!syntax.empty() && (syntax.back() == '\0' || syntax.back() == ' ')) syntax.pop_back();
    while (!sop_class_.empty() && (sop_class_.back() == '\0' || sop_class_.back() == ' '))
      sop_class_.pop_back();
    if (syntax == "1.2.840.10008.1.2.1.99") return Result::unsure;  // deflated data set
    explicit_vr_ = syntax != "1.2.840.10008.1.2";
    big_endian_ = syntax == "1.2.840.10008.1.2.2";
    return Result::complete;
  }

  // Elements up to the end of the file, or (inside an item) up to the item delimiter.
  Result walk_dataset(bool in_item) {
    Header h;
    while (pos_ < bytes_.size()) {
      if (!header(h)) return Result::truncated;
      if (h.group == 0xfffe && h.element == 0xe00d) return Result::complete;  // end of item
      const bool pixel_data = !in_item && h.group == 0x7fe0 && h.element == 0x0010;
      if (h.length != kUndefined) {
        if (!skip(h.length)) return Result::truncated;
        has_pixel_data_ = has_pixel_data_ || pixel_data;
        continue;
      }
      const Result r = walk_undefined_sequence(h);
      if (r != Result::complete) return r;
      has_pixel_data_ = has_pixel_data_ || pixel_data;
    }
    return in_item ? Result::truncated : Result::complete;
  }

  // A sequence (or encapsulated pixel data) of undefined length: items up to the delimiter.
  Result walk_undefined_sequence(const Header& owner) {
    const bool saved_explicit = explicit_vr_;
    if (owner.vr[0] == 'U' && owner.vr[1] == 'N') explicit_vr_ = false;  // UN: implicit inside
    Header h;
    Result result = Result::truncated;
    while (header(h)) {
      if (h.group == 0xfffe && h.element == 0xe0dd) {
        result = Result::complete;
        break;
      }
      if (h.group != 0xfffe || h.element != 0xe000) {
        result = Result::unsure;
        break;
      }
      if (h.length == kUndefined) {
        result = walk_dataset(true);
        if (result != Result::complete) break;
        result = Result::truncated;
      } else if (!skip(h.length)) {
        break;
      }
    }
    explicit_vr_ = saved_explicit;
    return result;
  }

  std::vector<char> bytes_;
  std::string sop_class_;
  bool has_pixel_data_ = false;
  std::size_t pos_ = 0;
  bool explicit_vr_ = true;
  bool big_endian_ = false;
};

}  // namespace palp
