// The Falcon's FTDI framing and runtime frames (falcon_protocol.hpp).
#include "usb/falcon_protocol.hpp"

namespace palp::usb::falcon {
namespace {

void put_word(std::uint16_t value, std::uint8_t* out) {
  for (int n = 0; n < 4; ++n)
    out[n] = static_cast<std::uint8_t>(kNibbleBase + ((value >> (4 * n)) & 0x0f));
}

bool get_word(const std::uint8_t* in, std::uint16_t& value) {
  value = 0;
  for (int n = 0; n < 4; ++n) {
    const int nibble = int(in[n]) - kNibbleBase;
    if (nibble < 0 || nibble > 0x0f) return false;
    value = static_cast<std::uint16_t>(value | (nibble << (4 * n)));
  }
  return true;
}

bool delimited(const std::uint8_t in[kFrameSize]) {
  return in[0] == kFrameStart && in[kFrameSize - 1] == kFrameEnd;
}

}  // namespace

bool strip_ftdi_status(const std::uint8_t* packet, std::size_t size, const std::uint8_t*& data,
                       std::size_t& data_size) {
  if (size < kFtdiStatusBytes) return false;
  data = packet + kFtdiStatusBytes;
  data_size = size - kFtdiStatusBytes;
  return true;
}

void encode_host_frame(const HostFrame& frame, std::uint8_t out[kFrameSize]) {
  out[0] = kFrameStart;
  for (int i = 0; i < 3; ++i)
    put_word(static_cast<std::uint16_t>(frame.efforts[static_cast<std::size_t>(i)]),
             out + 1 + 4 * i);
  out[13] = static_cast<std::uint8_t>(kNibbleBase + (frame.control & 0x0f));
  out[14] = kNibbleBase;
  out[15] = kFrameEnd;
}

void encode_device_frame(const DeviceFrame& frame, std::uint8_t out[kFrameSize]) {
  out[0] = kFrameStart;
  for (int i = 0; i < 3; ++i)
    put_word(static_cast<std::uint16_t>(frame.encoders[static_cast<std::size_t>(i)]),
             out + 1 + 4 * i);
  out[13] =
      static_cast<std::uint8_t>(kNibbleBase + (frame.buttons & 0x0f) + ((frame.homed & 7) << 4));
  out[14] = kNibbleBase;
  out[15] = kFrameEnd;
}

bool decode_host_frame(const std::uint8_t in[kFrameSize], HostFrame& frame) {
  if (!delimited(in)) return false;
  for (int i = 0; i < 3; ++i) {
    std::uint16_t v = 0;
    if (!get_word(in + 1 + 4 * i, v)) return false;
    frame.efforts[static_cast<std::size_t>(i)] = static_cast<std::int16_t>(v);
  }
  const int control = int(in[13]) - kNibbleBase, spare = int(in[14]) - kNibbleBase;
  if (control < 0 || control > 0x0f || spare < 0 || spare > 0x0f) return false;
  frame.control = static_cast<std::uint8_t>(control);
  return true;
}

bool decode_device_frame(const std::uint8_t in[kFrameSize], DeviceFrame& frame) {
  if (!delimited(in)) return false;
  for (int i = 0; i < 3; ++i) {
    std::uint16_t v = 0;
    if (!get_word(in + 1 + 4 * i, v)) return false;
    frame.encoders[static_cast<std::size_t>(i)] = static_cast<std::int16_t>(v);
  }
  const int status = int(in[13]) - kNibbleBase, spare = int(in[14]) - kNibbleBase;
  if (status < 0 || status > 0x7f || spare < 0 || spare > 0x0f) return false;
  frame.buttons = static_cast<std::uint8_t>(status & 0x0f);
  frame.homed = static_cast<std::uint8_t>((status >> 4) & 7);
  return true;
}

bool FrameParser::push(std::uint8_t byte) {
  if (fill_ == 0) {
    if (byte != kFrameStart) {
      ++counters_.skipped;
      return false;
    }
    buffer_[fill_++] = byte;
    return false;
  }
  if (fill_ < kFrameSize - 1) {
    if (byte == kFrameStart || byte == kFrameEnd) {
      // a frame cut short: resync on this '<' (or wait for the next one after a '>')
      ++counters_.short_frames;
      fill_ = 0;
      if (byte == kFrameStart) buffer_[fill_++] = byte;
      return false;
    }
    buffer_[fill_++] = byte;
    return false;
  }
  // the 16th byte
  fill_ = 0;
  if (byte != kFrameEnd) {
    ++counters_.corrupt;
    if (byte == kFrameStart) buffer_[fill_++] = byte;
    return false;
  }
  buffer_[kFrameSize - 1] = byte;
  return true;
}

}  // namespace palp::usb::falcon
