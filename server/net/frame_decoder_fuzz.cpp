// libFuzzer target for the client-side input path of palpd: bytes off the socket ->
// wire::FrameDecoder
// -> parse_client_message. Built only with clang and -DPALP_FUZZ=ON (see server/CMakeLists.txt):
//   cmake -S . -B build-fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang \
//         -DPALP_FUZZ=ON -DPALP_BUILD_TESTS=OFF && ninja -C build-fuzz frame_decoder_fuzz
//   build-fuzz/server/frame_decoder_fuzz -max_total_time=60
// CTest runs it for 20 s over the seeds in tests/fuzz/frame_decoder_corpus wherever clang++ with
// libFuzzer is installed (tests/fuzz/CMakeLists.txt builds it with clang whatever compiles the
// rest); tests/proto/wire/framing_test.cpp and tests/server/net/protocol_test.cpp run a
// deterministic mutation pass over the same path everywhere.
#include <cstddef>
#include <cstdint>
#include <cstdlib>

#include "net/protocol.hpp"
#include "wire/framing.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace wire = palp::wire;
  using palp::net::parse_client_message;
  // The first byte picks the size of the pieces the stream arrives in (1..256 bytes).
  if (size == 0) return 0;
  const std::size_t piece = static_cast<std::size_t>(data[0]) + 1;
  ++data, --size;
  (void)wire::peek_frame({data, size}, wire::kDefaultMaxClientFrame);
  wire::FrameDecoder decoder(wire::kDefaultMaxClientFrame);
  palp::v1::ClientMessage message;
  for (std::size_t at = 0; at < size; at += piece) {
    const std::size_t n = size - at < piece ? size - at : piece;
    decoder.feed(data + at, n);
    std::string_view body;
    wire::FrameStatus status;
    while ((status = decoder.next(body)) == wire::FrameStatus::Ok) {
      if (body.size() > wire::kDefaultMaxClientFrame) std::abort();
      (void)parse_client_message(body, message);
    }
    if (status != wire::FrameStatus::Incomplete) break;
  }
  return 0;
}
