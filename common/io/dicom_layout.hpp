// A structural check of DICOM Part 10 files before GDCM sees them. GDCM reads a file whose last
// element is cut short (a truncated transfer) as if it were whole, and it reads every element it
// walks into memory; so the DICOM reader first walks the elements itself, through a small
// window (the file is never in memory whole), to check that
// - each element lies within the file (a length beyond the file's end is a truncation),
// - the elements of a data set come in ascending tag order (a sparse file of zeros repeats the
//   tag (0000,0000) and stops at once),
// - the file has at most kMaxElements elements, sequences nest at most kMaxDepth deep, and the
//   bytes outside the top-level Pixel Data stay within kMaxHeaderBytes,
// and to learn the transfer syntax and how many bytes the Pixel Data holds, which bound what
// the image may claim to decode to (dicom.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace palp {

// Walks the elements of a Part 10 file (little or big endian, explicit or implicit VR, nested
// sequences and encapsulated pixel data).
class DicomLayoutCheck {
 public:
  // complete: every element walked. truncated: an element runs past the end of the file.
  // unsure: the layout cannot be walked (a deflated data set, an odd sequence), GDCM decides.
  // refused: one of the limits above; reason() says which.
  enum class Result { complete, truncated, unsure, refused };

  static constexpr std::uint64_t kMaxHeaderBytes = std::uint64_t{64} << 20;
  static constexpr std::uint64_t kMaxElements = 100000;
  static constexpr int kMaxDepth = 32;

  // The bytes of a whole file held in memory.
  explicit DicomLayoutCheck(std::vector<char> bytes);
  // The file at `path`, read through a 64 KiB window. InputError when it cannot be opened or is
  // not a regular file.
  explicit DicomLayoutCheck(const std::string& path);
  ~DicomLayoutCheck();
  DicomLayoutCheck(const DicomLayoutCheck&) = delete;
  DicomLayoutCheck& operator=(const DicomLayoutCheck&) = delete;

  Result run();

  // After run(): why it refused the file.
  const std::string& reason() const { return reason_; }
  // After run(): the SOP class and transfer syntax the file meta names (trailing padding
  // removed), whether the top-level data set holds a whole Pixel Data element, and that
  // element's value bytes (for encapsulated data, the sum of its items). A file cut exactly at
  // an element boundary walks as complete; only an image class without its pixels shows the cut.
  const std::string& media_storage_sop_class() const { return sop_class_; }
  const std::string& transfer_syntax() const { return syntax_; }
  bool has_pixel_data() const { return has_pixel_data_; }
  std::uint64_t pixel_data_bytes() const { return pixel_data_bytes_; }
  std::uint64_t file_bytes() const { return size_; }

 private:
  static constexpr std::uint32_t kUndefined = 0xffffffffu;
  struct Header {
    std::uint16_t group = 0, element = 0;
    std::uint32_t length = 0;
    char vr[2] = {0, 0};
  };

  bool fits(std::uint64_t n) const { return pos_ <= size_ && n <= size_ - pos_; }
  // Copies n bytes at `at` (within the file) into dst.
  void fetch(std::uint64_t at, std::size_t n, char* dst);
  std::uint32_t read_uint(std::uint64_t at, int size);
  std::string read_text(std::uint64_t at, std::uint32_t length);
  bool header(Header& h);
  bool skip(std::uint32_t length);
  Result refuse(const std::string& why);
  Result walk_file_meta();
  Result walk_dataset(bool in_item, int depth);
  Result walk_undefined_sequence(const Header& owner, bool pixel_data, int depth);

  std::vector<char> bytes_;  // memory source
  int fd_ = -1;              // file source
  std::vector<char> window_;
  std::uint64_t window_at_ = 0;
  std::size_t window_size_ = 0;

  std::uint64_t size_ = 0;
  std::uint64_t pos_ = 0;
  std::uint64_t elements_ = 0;
  std::uint64_t pixel_data_bytes_ = 0;
  std::string sop_class_;
  std::string syntax_;
  std::string reason_;
  bool has_pixel_data_ = false;
  bool explicit_vr_ = true;
  bool big_endian_ = false;
};

}  // namespace palp
