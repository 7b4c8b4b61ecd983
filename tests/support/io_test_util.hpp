// Helpers for the CT I/O tests: a per-test temporary directory, whole-file byte I/O, and an
// assertion that a statement throws a given palp error whose one-line message has a fragment.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace palp::testing {

// A fresh directory, removed afterwards: named after the running test, or after `label`.
class TempDir {
 public:
  TempDir() : TempDir("io-" + running_test_name()) {}
  explicit TempDir(const std::string& label) {
    path_ = std::filesystem::temp_directory_path() /
            ("palp-" + label + "-" + std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

 private:
  static std::string running_test_name() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string(info->test_suite_name()) + "-" + info->name();
    for (char& c : name)
      if (c == '/') c = '_';
    return name;
  }

  std::filesystem::path path_;
};

inline void write_bytes(const std::string& path, const void* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary);
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
  ASSERT_TRUE(out.good()) << path;
}

inline void write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  write_bytes(path, bytes.data(), bytes.size());
}

// Compressible but not trivial test data (runs of 97 bytes over 13 levels, with noise).
inline std::vector<std::uint8_t> compressible_bytes(std::size_t n) {
  std::vector<std::uint8_t> out(n);
  std::uint32_t state = 12345;
  for (std::size_t i = 0; i < n; ++i) {
    state = state * 1664525u + 1013904223u;
    out[i] = static_cast<std::uint8_t>((i / 97) % 13 + ((state >> 24) & 3));
  }
  return out;
}

inline void write_text(const std::string& path, const std::string& text) {
  write_bytes(path, text.data(), text.size());
}

inline std::vector<std::uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Writes the bytes of a trivially copyable value at `offset` (host byte order, or swapped).
template <class T>
void put(std::vector<std::uint8_t>& out, std::size_t offset, T value, bool swap = false) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (swap) std::reverse(bytes, bytes + sizeof(T));
  if (out.size() < offset + sizeof(T)) out.resize(offset + sizeof(T));
  std::memcpy(out.data() + offset, bytes, sizeof(T));
}

template <class T>
T get(const std::vector<std::uint8_t>& in, std::size_t offset) {
  T value;
  std::memcpy(&value, in.data() + offset, sizeof(T));
  return value;
}

// Appends the bytes of a trivially copyable value (host byte order, or swapped).
template <class T>
void append(std::vector<std::uint8_t>& out, T value, bool swap = false) {
  std::uint8_t bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if (swap) std::reverse(bytes, bytes + sizeof(T));
  out.insert(out.end(), bytes, bytes + sizeof(T));
}

// Twelve int16 CT values spanning air to dense bone, for hand-written image files.
inline const std::vector<std::int16_t> kSampleHu{-1024, -500, 0,    1,    2,    3,
                                                 40,    500,  1000, 2000, 3000, -5};

// The values' bytes, little-endian on this host or swapped (`swap` = big-endian).
template <class T>
std::vector<std::uint8_t> payload(const std::vector<T>& values, bool swap = false) {
  std::vector<std::uint8_t> out;
  for (const T v : values) append(out, v, swap);
  return out;
}

// A file holding a text header followed by binary data (an attached NRRD, a LOCAL .mha).
inline void write_header_and_data(const std::string& path, const std::string& header,
                                  const std::vector<std::uint8_t>& data) {
  std::vector<std::uint8_t> bytes(header.begin(), header.end());
  bytes.insert(bytes.end(), data.begin(), data.end());
  write_bytes(path, bytes);
}

// Resident memory the process has gained since the last reset_peak_memory(), from VmHWM (the
// kernel resets the high-water mark when "5" is written to /proc/self/clear_refs).
inline void reset_peak_memory() {
  std::ofstream("/proc/self/clear_refs") << "5";
}

inline std::size_t peak_memory_bytes() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmHWM:") {
      std::size_t kib = 0;
      status >> kib;
      return kib * 1024;
    }
    status.ignore(1 << 12, '\n');
  }
  return 0;
}

}  // namespace palp::testing

// Expects `statement` to throw `ErrorType` with a single-line message containing `fragment`.
#define EXPECT_PALP_ERROR(statement, ErrorType, fragment)                               \
  do {                                                                                  \
    try {                                                                               \
      statement;                                                                        \
      ADD_FAILURE() << "expected " #ErrorType " containing \"" << (fragment) << "\"";   \
    } catch (const ErrorType& error_) {                                                 \
      const std::string message_ = error_.what();                                       \
      EXPECT_NE(message_.find(fragment), std::string::npos) << "message: " << message_; \
      EXPECT_EQ(message_.find('\n'), std::string::npos) << "multi-line: " << message_;  \
    }                                                                                   \
  } while (false)
