// Message framing on the wire (spec "Wire protocol"): each message is a varint length prefix
// (protobuf base-128, least significant group first) followed by that many bytes of one
// serialized protobuf message - the "delimited" form other protobuf runtimes read and write.
//
// Everything here is pure and bounded: no protobuf, no sockets. peek_frame() is the decoder the
// fuzz target and the mutation test exercise; FrameDecoder wraps it for a byte stream.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace palp::wire {

inline constexpr std::size_t kMaxVarintBytes = 10;
// Largest client message palpd accepts (Hello, Command, DevicePose are small).
inline constexpr std::size_t kDefaultMaxClientFrame = 64 * 1024;
// Largest server message a client accepts (a volume chunk is at most about 2 MB).
inline constexpr std::size_t kDefaultMaxServerFrame = 16 * 1024 * 1024;

// Writes `value` as a varint into out[0..10); returns the number of bytes.
std::size_t encode_varint(std::uint64_t value, std::uint8_t* out) noexcept;
// Appends the prefix for `body` and `body` itself.
void append_frame(std::string& out, std::string_view body);

enum class FrameStatus {
  Ok,          // a complete frame: prefix_bytes + body_bytes bytes
  Incomplete,  // more bytes are needed
  TooLarge,    // the prefix announces more than the limit (detected from the prefix alone)
  BadPrefix,   // the prefix runs over 10 bytes or past 64 bits
};
const char* to_string(FrameStatus status);

struct FrameView {
  FrameStatus status = FrameStatus::Incomplete;
  std::size_t prefix_bytes = 0;
  std::size_t body_bytes = 0;  // announced length (valid for Ok and TooLarge)
};

// Examines the start of `data` for one frame whose body may hold at most `max_body` bytes.
FrameView peek_frame(std::span<const std::uint8_t> data, std::size_t max_body) noexcept;

// A byte-stream decoder: feed() what the socket delivered, then take frames with next() until it
// says Incomplete. TooLarge and BadPrefix are sticky: the stream cannot be resynchronised.
class FrameDecoder {
 public:
  explicit FrameDecoder(std::size_t max_body = kDefaultMaxClientFrame) : max_body_(max_body) {}
  void feed(const std::uint8_t* data, std::size_t size);
  // Ok: `body` is valid until the next feed() or next().
  FrameStatus next(std::string_view& body);
  std::size_t buffered() const { return buffer_.size() - start_; }
  std::size_t max_body() const { return max_body_; }

 private:
  std::size_t max_body_;
  std::string buffer_;
  std::size_t start_ = 0;
  FrameStatus error_ = FrameStatus::Ok;
};

}  // namespace palp::wire
