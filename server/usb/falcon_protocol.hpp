// The Novint Falcon's USB protocol, as pure functions (no libusb): the FTDI serial bridge's vendor
// requests and IN-packet framing, the DSP bootloader's handshake, and the 16-byte runtime frames
// of Novint's standard firmware. Sources (read as references, palp's own code): libnifalcon
// (BSD-3) src/comm/FalconCommLibUSB.cpp (FTDI requests, bootloader check bytes, baud divisors),
// src/core/FalconFirmware.cpp (chunked upload with echo), src/firmware/FalconFirmwareNovintSDK.cpp
// (frame layout); FTDI's AN232B-04 for the two modem-status bytes heading every IN packet.
//
//   USB: VID:PID 0403:cb48, interface 0, bulk OUT 0x02, bulk IN 0x81 (64-byte packets).
//   IN packet:   [modem status][line status][serial bytes ...]   (strip_ftdi_status)
//   host frame:  '<' e0 e0 e0 e0 e1 .. e1 e2 .. e2 ctl 0 '>'   16 bytes; each middle byte is
//                0x41 + one nibble; efforts are signed 16-bit, least significant nibble first
//                (palp sends at most +-falcon::kMaxEffort, 4095: docs/devices.md);
//                ctl = LED bits | homing-mode bit
//   device frame: '<' enc0 x4, enc1 x4, enc2 x4, status, 0 '>'  status - 0x41: bits 0-3 grip
//                buttons, bits 4-6 "homed" per motor
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace palp::usb::falcon {

inline constexpr std::uint16_t kVendor = 0x0403;   // FTDI
inline constexpr std::uint16_t kProduct = 0xcb48;  // Novint Falcon
inline constexpr std::uint8_t kEndpointOut = 0x02;
inline constexpr std::uint8_t kEndpointIn = 0x81;
inline constexpr std::size_t kUsbPacket = 64;
inline constexpr std::size_t kFtdiStatusBytes = 2;

// FTDI vendor requests (bmRequestType 0x40, wIndex 0 = the one port).
inline constexpr std::uint8_t kFtdiRequestType = 0x40;
inline constexpr std::uint8_t kSioReset = 0;        // wValue: 0 reset, 1 purge RX, 2 purge TX
inline constexpr std::uint8_t kSioModemCtrl = 1;    // DTR / RTS lines
inline constexpr std::uint8_t kSioSetFlowCtrl = 2;  // 0: none
inline constexpr std::uint8_t kSioSetBaudRate = 3;  // wValue: divisor
inline constexpr std::uint8_t kSioSetData = 4;      // 8: 8 data bits, no parity, 1 stop bit
inline constexpr std::uint8_t kSioSetLatency = 9;   // ms the bridge waits before a short IN
inline constexpr std::uint16_t kPurgeRx = 1, kPurgeTx = 2;
inline constexpr std::uint16_t kDtrLow = 0x0100, kDtrHigh = 0x0101;  // (mask << 8) | value
inline constexpr std::uint16_t kRtsLow = 0x0200, kRtsHigh = 0x0202;
inline constexpr std::uint16_t kData8N1 = 8;
// Baud divisors (FalconCommLibUSB.cpp): 9600 for the bootloader check, 140000 for the upload,
// and the runtime rate.
inline constexpr std::uint16_t kBaud9600 = 0x4138;
inline constexpr std::uint16_t kBaudUpload = 0x15;
inline constexpr std::uint16_t kBaudRuntime = 0x02;
inline constexpr std::uint16_t kLatencyBoot = 16, kLatencyRuntime = 1;

// Bootloader: after a DTR low -> high reset, at 9600 baud the host sends kBootProbe and the
// bootloader answers kBootProbeReply (some hosts see a leading 0x00 too); then DTR low, 140000
// baud, kBootEnter is echoed; then every firmware byte is echoed as it is taken.
inline constexpr std::array<std::uint8_t, 3> kBootProbe = {0x0a, 0x43, 0x0d};
inline constexpr std::array<std::uint8_t, 4> kBootProbeReply = {0x0a, 0x44, 0x2c, 0x0d};
inline constexpr std::uint8_t kBootEnter = 0x41;
// Upload chunk: a 64-byte packet less the 2 FTDI status bytes of its echo.
inline constexpr std::size_t kFirmwareChunk = 62;
// Novint's firmware files are a few tens of KiB; palp refuses anything empty or beyond this.
inline constexpr std::size_t kMaxFirmwareBytes = 256 * 1024;

inline constexpr std::size_t kFrameSize = 16;
inline constexpr std::uint8_t kFrameStart = '<', kFrameEnd = '>', kNibbleBase = 0x41;
// Host frame control bits. libnifalcon (github.com/libnifalcon/libnifalcon at f7c727a)
// include/falcon/core/FalconFirmware.h:68-70: GREEN_LED 0x2, BLUE_LED 0x4, RED_LED 0x8; the homing
// bit is OR-ed in as 0x01 (src/firmware/FalconFirmwareNovintSDK.cpp:93). palp had red 0x02,
// green 0x04, blue 0x08 before (a real Falcon would have shown green while homing, blue homed).
inline constexpr std::uint8_t kHomingMode = 0x01;
inline constexpr std::uint8_t kLedGreen = 0x02, kLedBlue = 0x04, kLedRed = 0x08;
// Grip buttons of the standard four-button grip, libnifalcon
// include/falcon/grip/FalconGripFourButton.h:40-43: PLUS 0x1, FORWARD 0x2, CENTER 0x4, MINUS 0x8
// (its examples/falcon_test_cli/FalconWallTest.cpp:38/46 reads the "center button" as BUTTON_3,
// 0x4, too).
inline constexpr std::uint8_t kButtonPlus = 0x01, kButtonForward = 0x02, kButtonCentre = 0x04,
                              kButtonMinus = 0x08;

struct HostFrame {
  std::array<std::int16_t, 3> efforts{};
  std::uint8_t control = 0;  // LED bits | kHomingMode
};
struct DeviceFrame {
  std::array<std::int16_t, 3> encoders{};
  std::uint8_t buttons = 0;  // 4 bits
  std::uint8_t homed = 0;    // bit i: motor i homed
  bool all_homed() const { return (homed & 7) == 7; }
};

// The serial bytes of one IN packet (after the two FTDI status bytes); size 0 for a status-only
// packet. False for a packet shorter than the status (counted as short by the caller).
bool strip_ftdi_status(const std::uint8_t* packet, std::size_t size, const std::uint8_t*& data,
                       std::size_t& data_size);

void encode_host_frame(const HostFrame& frame, std::uint8_t out[kFrameSize]);
void encode_device_frame(const DeviceFrame& frame, std::uint8_t out[kFrameSize]);
// False when a byte is out of its range (a corrupt frame) or the delimiters are wrong.
bool decode_host_frame(const std::uint8_t in[kFrameSize], HostFrame& frame);
bool decode_device_frame(const std::uint8_t in[kFrameSize], DeviceFrame& frame);

// The serial byte stream -> frames. Resyncs on '<' after anything corrupt or short; bounded state
// (one frame). feed() returns how many valid frames it delivered to `on_frame`.
class FrameParser {
 public:
  struct Counters {
    std::uint64_t frames = 0;        // valid frames
    std::uint64_t corrupt = 0;       // 16 bytes '<'..'>' with a byte out of range, or no '>' at 16
    std::uint64_t short_frames = 0;  // '>' or a new '<' before 16 bytes
    std::uint64_t skipped = 0;       // bytes outside any frame
  };
  template <typename F>
  std::size_t feed(const std::uint8_t* data, std::size_t size, F&& on_frame) {
    std::size_t delivered = 0;
    for (std::size_t i = 0; i < size; ++i)
      if (push(data[i])) {
        DeviceFrame frame;
        if (decode_device_frame(buffer_.data(), frame)) {
          ++counters_.frames;
          ++delivered;
          on_frame(frame);
        } else {
          ++counters_.corrupt;
        }
      }
    return delivered;
  }
  const Counters& counters() const { return counters_; }
  void reset() { fill_ = 0; }  // e.g. after a purge

 private:
  bool push(std::uint8_t byte);  // true when buffer_ holds 16 bytes '<' .. '>'
  std::array<std::uint8_t, kFrameSize> buffer_{};
  std::size_t fill_ = 0;
  Counters counters_;
};

}  // namespace palp::usb::falcon
