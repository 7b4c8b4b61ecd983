// Varint-delimited framing: exact bytes, every status, streaming, and a deterministic mutation run
// over the decoder (the CTest stand-in for the libFuzzer target fuzz/frame_decoder_fuzz.cpp).
#include "wire/framing.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace palp::wire {
namespace {

std::vector<std::uint8_t> bytes(std::initializer_list<int> list) {
  std::vector<std::uint8_t> out;
  for (int b : list) out.push_back(static_cast<std::uint8_t>(b));
  return out;
}

TEST(Varint, EncodesAsProtobufDoes) {
  std::uint8_t out[kMaxVarintBytes];
  EXPECT_EQ(encode_varint(0, out), 1u);
  EXPECT_EQ(out[0], 0);
  EXPECT_EQ(encode_varint(127, out), 1u);
  EXPECT_EQ(encode_varint(300, out), 2u);
  EXPECT_EQ(out[0], 0xac);
  EXPECT_EQ(out[1], 0x02);
  EXPECT_EQ(encode_varint(~0ull, out), 10u);
  EXPECT_EQ(out[9], 0x01);
}

TEST(PeekFrame, ReportsEveryStatus) {
  const auto ok = bytes({3, 'a', 'b', 'c', 'x'});
  FrameView v = peek_frame(ok, 100);
  EXPECT_EQ(v.status, FrameStatus::Ok);
  EXPECT_EQ(v.prefix_bytes, 1u);
  EXPECT_EQ(v.body_bytes, 3u);
  EXPECT_EQ(peek_frame(bytes({3, 'a'}), 100).status, FrameStatus::Incomplete);
  EXPECT_EQ(peek_frame({}, 100).status, FrameStatus::Incomplete);
  EXPECT_EQ(peek_frame(bytes({0x80}), 100).status, FrameStatus::Incomplete);
  EXPECT_EQ(peek_frame(bytes({0}), 100).status, FrameStatus::Ok);  // an empty message
  // 300 > 100: known from the prefix alone, before any body byte arrives.
  v = peek_frame(bytes({0xac, 0x02}), 100);
  EXPECT_EQ(v.status, FrameStatus::TooLarge);
  EXPECT_EQ(v.body_bytes, 300u);
  // Eleven continuation bytes, or a tenth byte carrying more than one bit.
  EXPECT_EQ(peek_frame(std::vector<std::uint8_t>(11, 0xff), ~std::size_t{0}).status,
            FrameStatus::BadPrefix);
  auto ten = std::vector<std::uint8_t>(9, 0xff);
  ten.push_back(0x02);
  EXPECT_EQ(peek_frame(ten, ~std::size_t{0}).status, FrameStatus::BadPrefix);
  // A non-minimal prefix is still a valid varint.
  v = peek_frame(bytes({0x81, 0x00, 'z'}), 100);
  EXPECT_EQ(v.status, FrameStatus::Ok);
  EXPECT_EQ(v.prefix_bytes, 2u);
  EXPECT_EQ(v.body_bytes, 1u);
}

TEST(FrameDecoder, ReassemblesFramesFedByteByByte) {
  std::string stream;
  const std::vector<std::string> bodies = {"", "x", std::string(200, 'y'), std::string(70000, 'z')};
  for (const auto& b : bodies) append_frame(stream, b);
  FrameDecoder d(1 << 20);
  std::vector<std::string> got;
  for (char c : stream) {
    d.feed(reinterpret_cast<const std::uint8_t*>(&c), 1);
    std::string_view body;
    while (d.next(body) == FrameStatus::Ok) got.emplace_back(body);
  }
  EXPECT_EQ(got, bodies);
  EXPECT_EQ(d.buffered(), 0u);
}

TEST(FrameDecoder, ErrorsAreSticky) {
  FrameDecoder d(10);
  const auto big = bytes({20});
  d.feed(big.data(), big.size());
  std::string_view body;
  EXPECT_EQ(d.next(body), FrameStatus::TooLarge);
  const auto ok = bytes({1, 'a'});
  d.feed(ok.data(), ok.size());
  EXPECT_EQ(d.next(body), FrameStatus::TooLarge);
}

// Random streams of frames, mutated (bit flips, cut, inserted and deleted bytes, random prefixes)
// and fed in random pieces: the decoder never reads outside what it was given, never returns a
// body over the limit, accounts for every byte of the frames it returns, and stops for good at
// the first error.
TEST(FrameDecoder, SurvivesMutatedStreams) {
  std::mt19937_64 rng(20261121);
  constexpr std::size_t kLimit = 4096;
  for (int round = 0; round < 3000; ++round) {
    std::string stream;
    const int frames = 1 + static_cast<int>(rng() % 6);
    for (int f = 0; f < frames; ++f) {
      std::string body(rng() % (round % 10 == 0 ? 6000 : 300), '\0');
      for (char& c : body) c = static_cast<char>(rng());
      append_frame(stream, body);
    }
    const int mutations = static_cast<int>(rng() % 5);
    for (int m = 0; m < mutations && !stream.empty(); ++m) {
      const std::size_t at = rng() % stream.size();
      switch (rng() % 5) {
        case 0:
          stream[at] = static_cast<char>(stream[at] ^ (1 << (rng() % 8)));
          break;
        case 1:
          stream.resize(at);
          break;
        case 2:
          stream.insert(at, 1, static_cast<char>(rng()));
          break;
        case 3:
          stream.erase(at, 1);
          break;
        default:
          stream.insert(at, std::string(1 + rng() % 12, static_cast<char>(0x80 | rng())));
          break;
      }
    }
    FrameDecoder d(kLimit);
    std::size_t fed = 0, consumed = 0;
    bool failed = false;
    while (fed < stream.size() && !failed) {
      const std::size_t piece = std::min<std::size_t>(stream.size() - fed, 1 + rng() % 700);
      d.feed(reinterpret_cast<const std::uint8_t*>(stream.data() + fed), piece);
      fed += piece;
      for (;;) {
        std::string_view body;
        const std::size_t before = d.buffered();
        const FrameStatus st = d.next(body);
        if (st == FrameStatus::Incomplete) break;
        if (st != FrameStatus::Ok) {
          failed = true;
          std::string_view again;
          ASSERT_EQ(d.next(again), st);
          break;
        }
        ASSERT_LE(body.size(), kLimit);
        const std::size_t frame = before - d.buffered();  // prefix (maybe non-minimal) + body
        ASSERT_GT(frame, body.size());
        ASSERT_LE(frame, body.size() + kMaxVarintBytes);
        consumed += frame;
        ASSERT_LE(consumed, fed);
      }
    }
    // Unless the stream failed, every byte fed is in a returned frame or still buffered.
    if (!failed) {
      ASSERT_EQ(consumed + d.buffered(), fed);
    }
  }
}

}  // namespace
}  // namespace palp::wire
