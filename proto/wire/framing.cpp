// Varint-delimited framing: see framing.hpp.
#include "wire/framing.hpp"

namespace palp::wire {

std::size_t encode_varint(std::uint64_t value, std::uint8_t* out) noexcept {
  std::size_t n = 0;
  while (value >= 0x80) {
    out[n++] = static_cast<std::uint8_t>(value | 0x80);
    value >>= 7;
  }
  out[n++] = static_cast<std::uint8_t>(value);
  return n;
}

void append_frame(std::string& out, std::string_view body) {
  std::uint8_t prefix[kMaxVarintBytes];
  const std::size_t n = encode_varint(body.size(), prefix);
  out.append(reinterpret_cast<const char*>(prefix), n);
  out.append(body);
}

const char* to_string(FrameStatus status) {
  switch (status) {
    case FrameStatus::Ok:
      return "ok";
    case FrameStatus::Incomplete:
      return "incomplete";
    case FrameStatus::TooLarge:
      return "frame too large";
    case FrameStatus::BadPrefix:
      break;
  }
  return "bad length prefix";
}

FrameView peek_frame(std::span<const std::uint8_t> data, std::size_t max_body) noexcept {
  FrameView view;
  std::uint64_t length = 0;
  for (std::size_t i = 0; i < kMaxVarintBytes; ++i) {
    if (i >= data.size()) return view;  // Incomplete
    const std::uint8_t byte = data[i];
    const std::uint64_t group = byte & 0x7f;
    // The tenth byte may only carry the top bit of a 64-bit value.
    if (i == kMaxVarintBytes - 1 && group > 1) {
      view.status = FrameStatus::BadPrefix;
      return view;
    }
    length |= group << (7 * i);
    if (byte & 0x80) continue;
    view.prefix_bytes = i + 1;
    if (length > max_body) {
      view.status = FrameStatus::TooLarge;
      view.body_bytes = length > SIZE_MAX ? SIZE_MAX : static_cast<std::size_t>(length);
      return view;
    }
    view.body_bytes = static_cast<std::size_t>(length);
    view.status = data.size() - view.prefix_bytes >= view.body_bytes ? FrameStatus::Ok
                                                                     : FrameStatus::Incomplete;
    return view;
  }
  view.status = FrameStatus::BadPrefix;
  return view;
}

void FrameDecoder::feed(const std::uint8_t* data, std::size_t size) {
  if (error_ != FrameStatus::Ok) return;
  if (start_ > 0 && start_ == buffer_.size()) {
    buffer_.clear();
    start_ = 0;
  } else if (start_ > 4096 && start_ * 2 > buffer_.size()) {
    buffer_.erase(0, start_);
    start_ = 0;
  }
  buffer_.append(reinterpret_cast<const char*>(data), size);
}

FrameStatus FrameDecoder::next(std::string_view& body) {
  if (error_ != FrameStatus::Ok) return error_;
  const auto* begin = reinterpret_cast<const std::uint8_t*>(buffer_.data()) + start_;
  const FrameView view = peek_frame({begin, buffer_.size() - start_}, max_body_);
  if (view.status == FrameStatus::TooLarge || view.status == FrameStatus::BadPrefix) {
    error_ = view.status;
    return error_;
  }
  if (view.status != FrameStatus::Ok) return FrameStatus::Incomplete;
  body = std::string_view(buffer_.data() + start_ + view.prefix_bytes, view.body_bytes);
  start_ += view.prefix_bytes + view.body_bytes;
  return FrameStatus::Ok;
}

}  // namespace palp::wire
